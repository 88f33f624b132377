//! What to do about a failure, with this command line's flags: the library's failures
//! carry their numbers and a flag-free hint ([`detune::failure::Failure::hint`]); here
//! the hint names the flag that changes the outcome.

use detune::failure::Failure;

/// The help line for a failure, where the command line has better advice than the
/// library's hint.
pub fn advice(f: &Failure) -> Option<String> {
    use Failure::*;
    Some(match f {
        StepLimit { .. } => {
            "loosen --rtol/--atol or shorten the run; a very small step points to a singular pose".into()
        }
        StepSizeUnderflow { .. } => "the mechanism may be at a singular pose (a rank loss of the constraints) or the forces change abruptly; check the model, or loosen --rtol/--atol".into(),
        TooManySteps { .. } => "loosen --rtol/--atol or shorten the run".into(),
        Integrator { bad_input: true, .. } => "check --t-end, --rtol and --atol".into(),
        ConstraintsNotKept { .. } => "tighten --rtol/--atol (the defaults are 1e-10 and 1e-12); if that does not help, the mechanism may pass a singular pose".into(),
        ContinuationStalled { .. } => "the branch may end here (a singular pose or no equilibrium), or --step is far too large for this model (the default is the range / 50): try a smaller --step".into(),
        BranchTurns { .. } => "the branch may end here (a singular pose); try a smaller --step".into(),
        SingularStart => "start away from it: --set the initial value of the coordinate the model fixes for assembly to another value".into(),
        NoEquilibrium { .. } => "start closer to an equilibrium (e.g. --set the initial angle), or check that one exists for these loads".into(),
        _ => return None,
    })
}
