//! The commands of the `detune` binary, one file each, and what they share: argument
//! groups ([`args`]), the progress bar, the signal flag, printing JSON.
//!
//! The command line parses arguments, shows progress, handles signals and turns errors
//! into advice; the work itself is the library's.

pub mod advice;
pub mod args;
pub mod backbone;
pub mod check;
pub mod r#continue;
pub mod draw;
pub mod equilibrium;
pub mod frf;
pub mod kinematics;
pub mod margins;
pub mod merge;
pub mod modes;
pub mod nfr;
pub mod report;
pub mod sensitivity;
pub mod simulate;
pub mod sweep;
pub mod tune;

use std::sync::atomic::{AtomicBool, AtomicI32, AtomicI64, Ordering};

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

/// Set by SIGINT, SIGTERM or SIGHUP (see [`handle_signals`]) once a command called
/// [`interrupt_on_ctrl_c`]: a long run stops at its next step and writes what it has.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The first signal received (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);
/// The running command checks [`INTERRUPTED`] between its steps.
static POLLS: AtomicBool = AtomicBool::new(false);
/// When the first signal came (CLOCK_MONOTONIC, ms).
static FIRST_AT_MS: AtomicI64 = AtomicI64::new(0);

/// A repeat of the first signal within this time is the same request, not a second one:
/// GNU `timeout` sends its SIGTERM twice (to the process, then to its process group), and
/// a shell or a scheduler may do the same.
const REPEAT_MS: i64 = 1000;

/// Milliseconds of CLOCK_MONOTONIC (async-signal-safe: clock_gettime is).
#[cfg(unix)]
fn monotonic_ms() -> i64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given; it is async-signal-safe.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as i64 * 1000 + ts.tv_nsec as i64 / 1_000_000
}

/// SIGINT, SIGTERM and SIGHUP, handled alike from the start of `main`: a command that
/// checks [`INTERRUPTED`] (it called [`interrupt_on_ctrl_c`]) gets the flag set, stops
/// at its next step, keeps its partial results where meaningful and exits 128 + the
/// signal (130, 143, 129: [`interrupted_by`]). Any other command, or a second signal
/// (during the write, say), ends the process at once with that code after unlinking its
/// temporary files ([`detune::output::commit::remove_temps_now`]), so no `.detune-*`
/// file lingers. The first signal repeated within a second ([`REPEAT_MS`]) is not a
/// second signal: GNU `timeout` sends SIGTERM twice.
///
/// Written with `libc::sigaction` rather than `ctrlc`: ctrlc's handler is not told which
/// signal came, and the exit code must say it.
pub fn handle_signals() {
    #[cfg(unix)]
    for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        // SAFETY: a zeroed sigaction with a handler that only does async-signal-safe work
        // (atomics, unlink, write, _exit).
        unsafe {
            let mut sa: libc::sigaction = std::mem::zeroed();
            sa.sa_sigaction = on_signal as *const () as libc::sighandler_t;
            sa.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut sa.sa_mask);
            libc::sigaction(sig, &sa, std::ptr::null_mut());
        }
    }
}

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    INTERRUPTED.store(true, Ordering::SeqCst);
    let now = monotonic_ms();
    let first = SIGNAL
        .compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst)
        .is_ok();
    if first {
        FIRST_AT_MS.store(now, Ordering::SeqCst);
    }
    // the same signal again at once: the same request (a handler runs with its own signal
    // blocked, so the first one's time is stored before a repeat is handled)
    let repeat = !first
        && SIGNAL.load(Ordering::SeqCst) == sig
        && now - FIRST_AT_MS.load(Ordering::SeqCst) < REPEAT_MS;
    let first = first || repeat;
    // blocked on a FIFO with no reader (or one that does not read): the run polls no
    // more, so the first signal ends it
    let blocked = detune::output::commit::writing_special();
    if first && POLLS.load(Ordering::SeqCst) && !blocked {
        return;
    }
    detune::output::commit::remove_temps_now();
    let msg: &[u8] = if blocked {
        b"\ninterrupted while writing to a FIFO or device (no reader?): that output is not written; the files written before it are kept\n"
    } else {
        b"\ninterrupted: stopped; no output written\n"
    };
    // SAFETY: write(2) and _exit(2) are async-signal-safe.
    unsafe {
        libc::write(2, msg.as_ptr().cast(), msg.len());
        // the first signal names the exit code
        libc::_exit(128 + SIGNAL.load(Ordering::SeqCst));
    }
}

/// From now on the running command checks [`INTERRUPTED`] between its steps: SIGINT,
/// SIGTERM or SIGHUP set it instead of ending the process (see [`handle_signals`]).
pub fn interrupt_on_ctrl_c() {
    POLLS.store(true, Ordering::SeqCst);
}

/// The signal that interrupted the run, if one did, as its exit code: 130 (SIGINT),
/// 143 (SIGTERM), 129 (SIGHUP).
pub fn interrupted_by() -> Option<i32> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        s => Some(128 + s),
    }
}

/// Set by a command whose work ran to its end uninterrupted ([`results_complete`]).
static COMPLETE: AtomicBool = AtomicBool::new(false);

/// The running command's results are complete: its work ran to its end (its own stop
/// state says so: a signal that came after its last check stopped nothing), and what it writes from now on is the whole result. A signal that comes
/// after this (while the outputs are rendered and committed) no longer stops anything:
/// the outputs are finished and committed, and the run exits 0, saying on stderr that
/// the signal came after the results were complete ([`exit_code_after`]).
pub fn results_complete() {
    COMPLETE.store(true, Ordering::SeqCst);
}

/// The exit code of a command that returned an error: 1, or 128 + the signal if one
/// interrupted it before its results were complete.
pub fn exit_code_of_error() -> i32 {
    match interrupted_by() {
        Some(signal) if !COMPLETE.load(Ordering::SeqCst) => signal,
        _ => 1,
    }
}

/// The exit code of a command that returned `Ok`: 128 + the signal if one interrupted
/// it; 0 (with a note on stderr) if the signal came only after its results were
/// complete ([`results_complete`]), its outputs all written; else `code`.
pub fn exit_code_after(code: i32) -> i32 {
    match interrupted_by() {
        Some(_) if COMPLETE.load(Ordering::SeqCst) => {
            let name = match SIGNAL.load(Ordering::SeqCst) {
                libc::SIGINT => "SIGINT",
                libc::SIGTERM => "SIGTERM",
                libc::SIGHUP => "SIGHUP",
                _ => "a signal",
            };
            eprintln!("note: {name} received after the results were complete; outputs written");
            code
        }
        Some(signal) => signal,
        None => code,
    }
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

/// Watches a command's stepped-sine sweeps (`sweep`, `sensitivity --method sweep|both`,
/// `tune --verify sweep`) for an integration DOP853 finds stiff: the first one is told at
/// once on stderr (above the progress bar), with its numbers and `--integrator radau`,
/// and kept for the JSON's `warnings`; later ones are not repeated.
pub struct StiffWatch {
    first: std::sync::OnceLock<(String, detune::frequency::StiffAt)>,
    began: std::time::Instant,
    /// The forcing frequency's parameter, as the warning names it.
    param: String,
}

impl StiffWatch {
    pub fn new(param: &str) -> StiffWatch {
        StiffWatch {
            first: std::sync::OnceLock::new(),
            began: std::time::Instant::now(),
            param: param.to_string(),
        }
    }

    fn context(&self, case: &str, at: &detune::frequency::StiffAt) -> String {
        format!(
            " at {} = {} rad/s{}",
            self.param,
            detune::output::num(at.omega),
            if case.is_empty() {
                String::new()
            } else {
                format!(" ({case})")
            }
        )
    }

    /// A sweep of `case` ("" for the command's own sweep) found `at` stiff: told unless
    /// one was told before.
    pub fn found(&self, case: &str, at: &detune::frequency::StiffAt, bar: &indicatif::ProgressBar) {
        if self.first.set((case.to_string(), at.clone())).is_ok() {
            let text = simulate::stiffness_warning_in(
                &at.stiffness,
                Some(self.began.elapsed()),
                &self.context(case, at),
                "this steady state's integration",
            );
            bar.suspend(|| eprintln!("{text}"));
        }
    }

    /// The JSON's `warnings`: empty, or the stiff integration with its numbers, the
    /// message and the help.
    pub fn warnings(&self) -> Vec<serde_json::Value> {
        let Some((case, at)) = self.first.get() else {
            return Vec::new();
        };
        let text = simulate::stiffness_warning_in(
            &at.stiffness,
            None,
            &self.context(case, at),
            "this steady state's integration",
        );
        let (message, help) = text.split_once("\nhelp: ").unwrap_or((&text, ""));
        let mut w = serde_json::json!({
            "kind": "stiff",
            "omega": at.omega,
            "message": message.trim_start_matches("warning: "),
            "help": help,
        });
        if !case.is_empty() {
            w["case"] = case.as_str().into();
        }
        if let (Some(map), Ok(serde_json::Value::Object(numbers))) =
            (w.as_object_mut(), serde_json::to_value(&at.stiffness))
        {
            map.extend(numbers);
        }
        vec![w]
    }
}

/// A `--json` document with the warnings of its run after its own keys (none: no key).
#[derive(serde::Serialize)]
pub struct Warned<T> {
    #[serde(flatten)]
    pub doc: T,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<serde_json::Value>,
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
