//! `detune report`: one self-contained HTML report for a design review, and its JSON
//! sidecar (every number shown, and the provenance) beside it.

use super::args::ModelArgs;
use clap::Args;
use detune::diag::{Error, Result};
use detune::report::{ReportInputs, build, environment};
use std::path::Path;
use std::time::Instant;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct ReportArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Vibration environment: a shipped one (UH-60, UH-1N, H135, AH-64) or an environment
    /// file; its forcing lines are shaded on the frequency response, drawn on the
    /// interference diagram and checked by the margins section.
    #[arg(long, value_name = "NAME|PATH")]
    pub environment: Option<String>,
    /// A varied parameter with its tolerance (as in `sensitivity`: `k_fs=±10%`), or with
    /// --tune its range (`k_fs=50%..200%`). Repeatable. Without it the sensitivity section
    /// varies each parameter by ±10 % as an illustration.
    #[arg(long = "vary", value_name = "NAME=CHANGE", allow_hyphen_values = true)]
    pub vary: Vec<String>,
    /// Required separation of every mode from every forcing line: "10%" or 0.1 (your
    /// choice, not a standard).
    #[arg(long, default_value = "10%", value_name = "PCT")]
    pub margin: String,
    /// Add a tuning proposal: the smallest change of the --tune-vary parameters within
    /// their ranges that clears every line by the margin. Needs --environment and
    /// --tune-vary (a usage error, exit 2, without them).
    #[arg(long, requires_all = ["environment", "tune_vary"])]
    pub tune: bool,
    /// A parameter the tuning may change, with its range (`k_fs=50%..200%`); separate
    /// from --vary (the tolerances). Repeatable; needed by --tune.
    #[arg(
        long = "tune-vary",
        value_name = "NAME=RANGE",
        allow_hyphen_values = true
    )]
    pub tune_vary: Vec<String>,
    /// Output HTML; the JSON sidecar is written beside it with the extension .json.
    #[arg(short = 'o', long = "output", value_name = "REPORT.html")]
    pub output: String,
    /// Unit of the frequencies the page shows: rad/s, Hz or rpm (rad/s beside them); the
    /// JSON sidecar stays in rad/s.
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
}

/// The sidecar's path: the page's with the extension `.json`.
pub fn sidecar_path(html: &str) -> String {
    Path::new(html)
        .with_extension("json")
        .to_string_lossy()
        .into_owned()
}

pub fn run(a: ReportArgs) -> Result<()> {
    let ext = Path::new(&a.output)
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("html" | "htm")) {
        return Err(Error::request(
            format!("-o {}: the report is an HTML file", a.output),
            "name it with .html, e.g. -o report.html (the JSON sidecar report.json is written beside it)",
        ));
    }
    let json = sidecar_path(&a.output);
    // the environment is checked before any work, like the outputs
    let margin = super::margins::parse_margin(&a.margin)?;
    let full_env = a
        .environment
        .as_deref()
        .map(detune::environment::resolve)
        .transpose()?;
    let env = full_env.as_ref().map(environment::from_environment);
    let (model, sys) = a.model.load()?;
    let mut inputs = vec![("model file", model.source.path.as_str())];
    if let Some(e) = full_env.as_ref().filter(|e| !e.shipped) {
        inputs.push(("environment file", e.file.as_str()));
    }
    // checked before any work; `Report::write` commits the page and its sidecar together
    let _outputs = detune::output::OutputSet::plan(&inputs, &[Some(&a.output), Some(&json)])?;
    if a.tune && (a.tune_vary.is_empty() || full_env.is_none()) {
        return Err(Error::request(
            "--tune needs the parameters the design may change, with their ranges, and an environment",
            "add --environment UH-60 and e.g. --tune-vary k_fs=50%..200% --tune-vary gearbox_scale=80%..120% (--vary gives the tolerances)",
        ));
    }
    if !a.tune && !a.tune_vary.is_empty() {
        return Err(Error::request(
            "--tune-vary gives the tuning's ranges, but no tuning is asked",
            "add --tune",
        ));
    }
    let tune_varies = super::args::varies_as(&model, &sys, &a.tune_vary, "--tune-vary")?;
    let given = !a.vary.is_empty();
    let (varies, dropped) = if given {
        (super::args::varies(&model, &sys, &a.vary)?, Vec::new())
    } else {
        detune::report::studies::default_varies(&sys, None)
    };
    let start = Instant::now();
    // names and energy shares of the modes (the model's [[modes]], mode tracking)
    let extras = detune::report::build::ModeExtras::of(&sys);
    let mut report = build(&ReportInputs {
        model: &model,
        sys: &sys,
        environment: env.as_ref(),
        mode_extras: extras.as_ref(),
        generated_utc: utc_now(),
        freq_unit: a.freq.freq_unit,
    })?;
    let unit = |name: &str| -> String { model.param_unit(name) };
    detune::report::studies::add_studies(
        &mut report,
        &detune::report::studies::Studies {
            sys: &sys,
            varies: &varies,
            given,
            dropped: &dropped,
            environment: full_env.as_ref(),
            margin,
            tune: a.tune,
            tune_varies: &tune_varies,
            units: &unit,
            vary_texts: &a.vary,
            command_words: &|except: &[&str]| a.model.command_words(except),
        },
    )?;
    // a --vary case that makes a damping coefficient negative (warned of on standard
    // error when parsed): in the sidecar's `warnings` and on the page
    if given {
        let warnings = super::args::damping_warnings(&model, &sys, &varies);
        if !warnings.is_empty() {
            report.add_data("warnings", &super::args::damping_warning_values(&warnings))?;
        }
        // and on the page, in the box at its top
        for w in warnings {
            report.warn(w);
        }
    }
    report.in_frequency_unit(a.freq.freq_unit);
    report.write(&a.output, &json)?;
    let modes = report
        .sidecar
        .get("modes")
        .and_then(|m| m.as_array())
        .map(|m| {
            m.iter()
                .map(|x| match x.get("omega_n_rad_s").and_then(|w| w.as_f64()) {
                    Some(w) => format!("{w:.3}"),
                    // a real eigenvalue has no ω_n: say which kind (`motion`)
                    None => x
                        .get("motion")
                        .and_then(|m| m.as_str())
                        .map(|m| {
                            if m == "divergent" {
                                "divergent"
                            } else {
                                "non-oscillatory"
                            }
                        })
                        .unwrap_or("divergent")
                        .to_string(),
                })
                .collect::<Vec<_>>()
        })
        .unwrap_or_default();
    // the crossing of a mode with a rotor line nearest the nominal rotor speed
    let nearest = report
        .sidecar
        .get("campbell/crossings")
        .and_then(|c| c.as_array())
        .and_then(|c| {
            c.iter()
                .filter_map(|x| {
                    Some((
                        x.get("mode_name")?.as_str()?,
                        x.get("line")?.as_str()?,
                        x.get("percent_nominal")?.as_f64()?,
                    ))
                })
                .min_by(|a, b| (a.2 - 100.0).abs().total_cmp(&(b.2 - 100.0).abs()))
                .map(|(m, l, p)| format!("; {m} meets {l} at {p:.1} % of the nominal rotor speed"))
        });
    println!("wrote {} and {json}", a.output);
    println!(
        "{}: {}{}; {} sections in {:.2} s",
        model.name,
        if modes.is_empty() {
            // no degrees of freedom (or no mode computed): nothing to list
            "no modes".to_string()
        } else {
            format!(
                "{} mode{} (ω_n {} rad/s)",
                modes.len(),
                if modes.len() == 1 { "" } else { "s" },
                modes.join(", ")
            )
        },
        nearest.unwrap_or_default(),
        report.document.sections.len(),
        start.elapsed().as_secs_f64()
    );
    // an unstable design says so here too, in the words `modes` and the page use
    let eq = |key: &str| report.sidecar.get(&format!("equilibrium/{key}")).cloned();
    let flag = |key: &str| eq(key).and_then(|v| v.as_bool());
    let (stable, dynamic) = (flag("stable"), flag("dynamically_stable"));
    if matches!((stable, dynamic), (Some(false), _) | (_, Some(false))) {
        let growing: Vec<detune::margins::UnstableMode> = eq("growing_modes")
            .and_then(|g| g.as_array().cloned())
            .unwrap_or_default()
            .iter()
            .filter_map(|u| {
                Some(detune::margins::UnstableMode {
                    mode: u.get("mode")?.as_str()?.to_string(),
                    growth_rate_1_s: u.get("growth_rate_1_s")?.as_f64()?,
                    omega_d_rad_s: u.get("omega_d_rad_s")?.as_f64()?,
                })
            })
            .collect();
        println!(
            "equilibrium: {}",
            detune::linear::stability_words(stable, dynamic, &growing)
        );
    }
    Ok(())
}

/// The current UTC time, `YYYY-MM-DDTHH:MM:SSZ`, from the system clock (days to a civil
/// date by H. Hinnant's algorithm; the standard library has no calendar, and this is too
/// small to take a date crate for).
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}
