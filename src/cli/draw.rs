//! `detune draw`: the assembled initial pose as an SVG drawing (front, side, top and
//! isometric views of a spatial model; the X–Y plane of a planar one).

use super::args::ModelArgs;
use clap::Args;
use detune::diag::Result;
use detune::draw::write_pose_svg;
use detune::output::check_outputs;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct DrawArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output SVG.
    #[arg(short = 'o', long = "output", value_name = "OUT.svg")]
    pub output: String,
}

pub fn run(a: DrawArgs) -> Result<()> {
    let (model, sys) = a.model.load_untrimmed()?;
    let outputs = check_outputs(&model.source.path, &[Some(&a.output)])?;
    // the drawing is SVG only: a `.png` (or any other name) is refused before any work,
    // never written as SVG under another name; a device or a pipe (/dev/stdout) takes it
    let special =
        a.output.starts_with("/dev/") || std::fs::metadata(&a.output).is_ok_and(|m| !m.is_file());
    let svg = std::path::Path::new(&a.output)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    if !svg && !special {
        return Err(detune::diag::Error::request(
            format!("-o {}: `draw` writes SVG only", a.output),
            "name the drawing `.svg`, e.g. -o pose.svg (a browser or `rsvg-convert` turns it into a bitmap)",
        ));
    }
    let start = detune::dynamics::assemble_at_rest(&sys)?;
    write_pose_svg(&a.output, &sys, &start.q, &model.name, &sys.force_names)?;
    outputs.commit()?;
    // not into the drawing itself when it goes to standard output
    if a.output == "/dev/stdout" {
        eprintln!("wrote {}", a.output);
    } else {
        println!("wrote {}", a.output);
    }
    Ok(())
}
