//! `detune kinematics`: the closure solved along a driven coordinate on the branch
//! through the assembled pose, with transmission ratios from its tangent.

use super::args::{ModelArgs, quantity};
use clap::Args;
use detune::diag::Result;
use detune::kinematics::{KinematicPath, KinematicsOptions, drive_index, kinematics};
use detune::output::check_outputs;
use detune::output::plot::write_panels_sized;

#[derive(Args)]
pub struct KinematicsArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The driven coordinate, e.g. stick.phi.
    #[arg(long, value_name = "NAME")]
    pub drive: String,
    /// First value of the drive: a number (SI: rad or m) or a quantity, e.g. "-15 deg".
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub from: String,
    /// Last value of the drive (included when the step divides the range).
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    pub to: String,
    /// Step of the drive, e.g. "0.5 deg".
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub step: String,
    /// Report d<drive>/d<NAME> from the closure's tangent (repeatable).
    #[arg(long, value_name = "NAME")]
    pub ratio: Vec<String>,
    /// CSV: `<drive>,<coordinates>...,d<drive>/d<NAME>...` in SI (angles in rad).
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// SVG: the ratios (or, without --ratio, every coordinate) against the drive, angles
    /// in degrees.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
}

pub fn run(a: KinematicsArgs) -> Result<()> {
    let (model, sys) = a.model.load_untrimmed()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let d = drive_index(&sys, &a.drive)?;
    let dim = sys.coordinate_dims[d];
    let opts = KinematicsOptions {
        drive: a.drive.clone(),
        from: quantity("--from", &a.from, &a.drive, dim)?,
        to: quantity("--to", &a.to, &a.drive, dim)?,
        step: quantity("--step", &a.step, &a.drive, dim)?,
        ratios: a.ratio.clone(),
    };
    let path = kinematics(&sys, &opts)?;
    if let Some(o) = &a.output {
        path.write_csv(o)?;
    }
    if let Some(p) = &a.plot {
        let caption = detune::output::figures::Case::of(&model).caption(&[]);
        let mut figures = path.figures(&model.name);
        if let Some(f) = figures.first_mut() {
            f.caption = caption;
        }
        write_panels_sized(p, &figures, size)?;
    }
    outputs.commit()?;
    if a.output.is_none() {
        print_table(&path);
    } else {
        note_dead_points(&path);
        let last = path.values.len() - 1;
        println!(
            "{} points, {} from {} to {}",
            path.values.len(),
            path.drive,
            shown(&path, d, path.values[0]),
            shown(&path, d, path.values[last])
        );
    }
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!("wrote {f}");
    }
    Ok(())
}

/// A value of coordinate `i` for people: degrees for an angle, else metres.
fn shown(path: &KinematicPath, i: usize, x: f64) -> String {
    if path.angles[i] {
        format!("{:.6}°", x.to_degrees())
    } else {
        format!("{x:.9} m")
    }
}

/// The path as a table on stdout: the drive, then the ratios (or, without them, every
/// other coordinate); angles in degrees.
fn print_table(path: &KinematicPath) {
    let d = path.drive_index;
    let unit = |i: usize| if path.angles[i] { "deg" } else { "m" };
    let shown = |i: usize, x: f64| if path.angles[i] { x.to_degrees() } else { x };
    let mut head = vec![format!("{} [{}]", path.drive, unit(d))];
    let others: Vec<usize> = (0..path.coordinates.len()).filter(|&i| i != d).collect();
    if path.ratio_names.is_empty() {
        head.extend(
            others
                .iter()
                .map(|&i| format!("{} [{}]", path.coordinates[i], unit(i))),
        );
    } else {
        head.extend(
            path.ratio_names
                .iter()
                .zip(&path.ratio_indices)
                .map(|(n, &i)| format!("d{}/d{n} [{}]", path.drive, path.ratio_unit(i))),
        );
    }
    let width = head
        .iter()
        .map(|h| h.chars().count())
        .max()
        .unwrap_or(12)
        .max(14);
    let line = |cells: Vec<String>| {
        cells
            .iter()
            .map(|c| format!("{c:>width$}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    println!("{}", line(head));
    for (k, v) in path.values.iter().enumerate() {
        let mut cells = vec![format!("{:.6}", shown(d, *v))];
        if path.ratio_names.is_empty() {
            cells.extend(
                others
                    .iter()
                    .map(|&i| format!("{:.9}", shown(i, path.q[k][i]))),
            );
        } else {
            cells.extend(path.ratios[k].iter().map(|r| format!("{r:.9}")));
        }
        println!("{}", line(cells));
    }
    note_dead_points(path);
}

/// Where a ratio is infinite, say why (on stderr): the coordinate is stationary there.
fn note_dead_points(path: &KinematicPath) {
    for (r, name) in path.ratio_names.iter().enumerate() {
        let at: Vec<String> = (0..path.values.len())
            .filter(|&k| path.ratios[k][r].is_infinite())
            .map(|k| shown(path, path.drive_index, path.values[k]))
            .collect();
        if !at.is_empty() {
            eprintln!(
                "note: d{}/d{name} is infinite at {} = {}: {name} is stationary there (it does not move with the drive)",
                path.drive,
                path.drive,
                at.join(", ")
            );
        }
    }
}
