//! The commands of the `detune` binary, one file each, and what they share: argument
//! groups ([`args`]), the progress bar, the Ctrl-C flag, printing JSON.
//!
//! The command line parses arguments, shows progress, handles Ctrl-C and turns errors
//! into advice; the work itself is the library's.

pub mod advice;
pub mod args;
pub mod check;
pub mod r#continue;
pub mod draw;
pub mod equilibrium;
pub mod frf;
pub mod kinematics;
pub mod margins;
pub mod modes;
pub mod report;
pub mod sensitivity;
pub mod simulate;
pub mod sweep;
pub mod tune;

use std::sync::atomic::{AtomicBool, Ordering};

/// How a command that ran to its end finished, for a command that checks something
/// (`margins`): the check passed (exit 0) or failed (exit 3). An error is not an outcome:
/// it is the command's `Err` (exit 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Passed,
    CheckFailed,
}

impl Outcome {
    /// The process exit code: 0 passed, 3 the check failed.
    pub fn exit_code(self) -> i32 {
        match self {
            Outcome::Passed => 0,
            Outcome::CheckFailed => 3,
        }
    }
}

/// Set by Ctrl-C once [`interrupt_on_ctrl_c`] is called: a long run stops and writes
/// what it has.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// From now on, Ctrl-C sets [`INTERRUPTED`] instead of ending the process.
pub fn interrupt_on_ctrl_c() {
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst));
}

/// A progress bar of `len` steps drawn with `template` (shown on a terminal only).
pub fn progress_bar(len: u64, template: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Print a JSON document on stdout, pretty.
pub fn print_json(v: &impl serde::Serialize) {
    println!("{}", serde_json::to_string_pretty(v).unwrap_or_default());
}

/// A coordinate's unit after its printed value: ` m`, or ` rad (12.000000°)` for an
/// angle (a quaternion component has none).
pub fn unit_and_degrees(sys: &detune::System, name: &str, v: f64) -> String {
    match sys.coordinate_index(name) {
        Some(i) if sys.is_angle(i) => format!(" rad ({:.6}°)", v.to_degrees()),
        Some(i) if sys.coordinate_dims[i] == detune::model::units::Dim::LENGTH => " m".into(),
        _ => String::new(),
    }
}
