//! The commands' JSON documents as `Serialize` types: `serde_json::to_string_pretty` of
//! one gives the command's keys, in order (serde_json keeps the order: `preserve_order`).
//!
//! Each document borrows the results it shows. Keys named after the model (coordinates,
//! responses, the `--values` parameter) are computed: [`Named`] and [`Tagged`] serialize
//! those, and the rows shared with the CSV files come from [`super::results`].

use super::Provenance;
use super::results::{Cell, frf_header, frf_rows, sweep_header, sweep_rows};
use crate::dynamics::simulate::{SimOptions, SimStats, Trajectory};
use crate::frequency::study::SweepRun;
use crate::frequency::{Hysteresis, Jump, Peak};
use crate::linear::{C64, FrequencyResponse, ModalAnalysis, ModeFields};
use crate::statics::Equilibrium;
use crate::statics::continuation::{Branch, BranchPoint};
use serde::Serialize;
use serde::ser::{Error as _, SerializeMap, Serializer};
use serde_json::{Map, Value};

/// `{name: value, ...}`: values by name, e.g. coordinates.
#[derive(Debug, Clone, Copy)]
pub struct Named<'a, T> {
    pub names: &'a [String],
    pub values: &'a [T],
}

impl<'a, T> Named<'a, T> {
    pub fn new(names: &'a [String], values: &'a [T]) -> Self {
        Named { names, values }
    }
}

impl<T: Serialize> Serialize for Named<'_, T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.names.len().min(self.values.len())))?;
        for (n, v) in self.names.iter().zip(self.values) {
            map.serialize_entry(n, v)?;
        }
        map.end()
    }
}

/// `item`'s object with more keys: each `--values` parameter and its value in this run
/// (none without `--values`).
#[derive(Debug, Clone)]
pub struct Tagged<'a, T> {
    pub item: T,
    pub tag: Vec<(&'a str, f64)>,
}

impl<T: Serialize> Serialize for Tagged<'_, T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = serde_json::to_value(&self.item).map_err(S::Error::custom)?;
        if let Value::Object(m) = &mut v {
            for (name, x) in &self.tag {
                m.insert(name.to_string(), Value::from(*x));
            }
        }
        v.serialize(s)
    }
}

/// A result row as an object, keyed by its CSV header. Built as a map: a key given twice
/// (a response named twice) appears once, where it first appears, with its last value.
pub(crate) fn row_object(header: &[String], row: &[Cell]) -> Map<String, Value> {
    header
        .iter()
        .cloned()
        .zip(row.iter().map(Cell::json))
        .collect()
}

/// The integrator settings a simulation summary reports.
#[derive(Debug, Clone, Serialize)]
pub struct SimSettings {
    pub t_end: f64,
    pub dt_out: f64,
    pub rtol: f64,
    pub atol: f64,
    /// Written when not the default (DOP853).
    #[serde(skip_serializing_if = "crate::dynamics::integrator::Integrator::is_default")]
    pub integrator: crate::dynamics::integrator::Integrator,
}

/// The last sample of a simulation.
#[derive(Debug, Clone, Serialize)]
pub struct FinalState<'a> {
    pub t: f64,
    pub coordinates: Named<'a, f64>,
}

/// `simulate --json`: provenance, options, step statistics, the final state and the CSV
/// written.
#[derive(Debug, Clone, Serialize)]
pub struct SimulationSummary<'a> {
    pub provenance: &'a Provenance,
    pub options: SimSettings,
    pub stats: &'a SimStats,
    #[serde(rename = "final")]
    pub final_state: FinalState<'a>,
    /// The CSV file written.
    pub output: &'a str,
    /// Whether the run reached its end time; false when a signal stopped it (the CSV then
    /// holds the samples up to the last one and ends with a `# incomplete: ...` line).
    pub complete: bool,
    /// The equilibrium the end state oscillates about (see [`SimulationSummary::with_wells`]):
    /// an index into `equilibria`, −1 across two wells.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub well: Option<isize>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub equilibria: Vec<WellJson<'a>>,
}

impl<'a> SimulationSummary<'a> {
    pub fn new(
        provenance: &'a Provenance,
        opts: &SimOptions,
        traj: &'a Trajectory,
        output: &'a str,
    ) -> Self {
        let last = traj.len() - 1;
        SimulationSummary {
            provenance,
            options: SimSettings {
                t_end: opts.t_end,
                dt_out: opts.dt_out,
                rtol: opts.rtol,
                atol: opts.atol,
                integrator: opts.integrator,
            },
            stats: &traj.stats,
            final_state: FinalState {
                t: traj.t[last],
                coordinates: Named::new(&traj.coordinates, traj.q(last)),
            },
            output,
            complete: true,
            well: None,
            equilibria: Vec::new(),
        }
    }

    /// With the end state's well and the equilibria it indexes.
    pub fn with_wells(mut self, wells: &'a crate::frequency::wells::Wells, well: isize) -> Self {
        self.well = Some(well);
        self.equilibria = wells
            .equilibria
            .iter()
            .enumerate()
            .map(|(k, e)| WellJson {
                index: k,
                coordinates: Named::new(self.final_state.coordinates.names, &e.q),
                stable: e.stable,
                dynamically_stable: wells.dynamically_stable.get(k).copied().flatten(),
                omega2: &e.omega2,
                start: k == wells.start,
            })
            .collect();
        self
    }
}

/// One equilibrium: coordinates, stability, Newton residual and iterations, ω².
#[derive(Debug, Clone, Serialize)]
pub struct EquilibriumJson<'a> {
    pub coordinates: Named<'a, f64>,
    /// `null` when nothing can move (no degrees of freedom: every coordinate fixed or
    /// driven), so there is no stability to speak of; see [`stability`].
    pub stable: Option<bool>,
    /// DYNAMIC stability: no mode of the linearization about this equilibrium grows
    /// ([`crate::linear::ModalAnalysis::dynamically_stable`]); with negative damping an
    /// equilibrium is `stable` (statically) and not dynamically stable. `null` with no
    /// degrees of freedom, or when its modes could not be computed.
    pub dynamically_stable: Option<bool>,
    pub residual: f64,
    pub iterations: usize,
    pub undamped_omega2: &'a [f64],
}

impl<'a> EquilibriumJson<'a> {
    /// `dynamic`: [`crate::linear::ModalAnalysis::dynamically_stable`] about `e`.
    pub fn new(names: &'a [String], e: &'a Equilibrium, dynamic: Option<bool>) -> Self {
        EquilibriumJson {
            coordinates: Named::new(names, &e.q),
            stable: stability(e),
            dynamically_stable: dynamic,
            residual: e.residual,
            iterations: e.iterations,
            undamped_omega2: &e.omega2,
        }
    }
}

/// `equilibrium --json`: the equilibrium's keys, then the provenance.
#[derive(Debug, Clone, Serialize)]
pub struct EquilibriumReport<'a> {
    #[serde(flatten)]
    pub equilibrium: EquilibriumJson<'a>,
    /// Parameters solved by the model's `[trim]` (SI), name → value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solved: Option<std::collections::BTreeMap<String, f64>>,
    /// Why the model's `[trim]` is off (a solved parameter given by the user).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trim: Option<String>,
    pub provenance: &'a Provenance,
}

/// `equilibrium --all --json`.
#[derive(Debug, Clone, Serialize)]
pub struct EquilibriaReport<'a> {
    pub equilibria: Vec<EquilibriumJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solved: Option<std::collections::BTreeMap<String, f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trim: Option<String>,
    pub provenance: &'a Provenance,
}

/// A fold or branch point: no `stable` flag, since the stiffness is singular there (the
/// point is marginal; stability changes across it).
#[derive(Debug, Clone, Serialize)]
pub struct BranchPointJson<'a> {
    pub value: f64,
    pub coordinates: Named<'a, f64>,
}

/// `continue --json`: folds, branch points, the number of points, whether the run
/// stopped at `--max-steps`.
#[derive(Debug, Clone, Serialize)]
pub struct BranchReport<'a> {
    pub param: &'a str,
    pub folds: Vec<BranchPointJson<'a>>,
    pub branch_points: Vec<BranchPointJson<'a>>,
    pub points: usize,
    pub truncated: bool,
    /// Every branch: 0 the one followed from the start (its points are the CSV's rows
    /// of `branch` 0), then those switched to at its branch points, each to one side.
    pub branches: Vec<BranchJson<'a>>,
    /// False when interrupted: the points are those computed until then.
    pub complete: bool,
    pub provenance: &'a Provenance,
}

/// One point of a branch in `continue --json`'s `branches`.
#[derive(Debug, Clone, Serialize)]
pub struct BranchPointStable<'a> {
    pub value: f64,
    pub coordinates: Named<'a, f64>,
    pub stable: bool,
}

/// One branch of `continue --json`: `from_branch_point` is the index in `branch_points`
/// of the branch point it leaves (absent for branch 0).
#[derive(Debug, Clone, Serialize)]
pub struct BranchJson<'a> {
    pub branch: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub from_branch_point: Option<usize>,
    pub points: Vec<BranchPointStable<'a>>,
    pub folds: Vec<BranchPointJson<'a>>,
    pub branch_points: Vec<BranchPointJson<'a>>,
    pub truncated: bool,
}

impl<'a> BranchReport<'a> {
    pub fn new(b: &'a Branch, provenance: &'a Provenance) -> Self {
        let points = |list: &'a [BranchPoint]| {
            list.iter()
                .map(|p| BranchPointJson {
                    value: p.value,
                    coordinates: Named::new(&b.coordinates, &p.q),
                })
                .collect()
        };
        BranchReport {
            param: &b.param,
            folds: points(&b.folds),
            branch_points: points(&b.branch_points),
            points: b.points.len(),
            truncated: b.truncated,
            branches: b
                .all()
                .into_iter()
                .enumerate()
                .map(|(k, (from, list, folds, bps, truncated))| BranchJson {
                    branch: k,
                    from_branch_point: from,
                    points: list
                        .iter()
                        .map(|p| BranchPointStable {
                            value: p.value,
                            coordinates: Named::new(&b.coordinates, &p.q),
                            stable: p.stable,
                        })
                        .collect(),
                    folds: points(folds),
                    branch_points: points(bps),
                    truncated,
                })
                .collect(),
            complete: b.complete,
            provenance,
        }
    }
}

/// One mode, its shape by coordinate name. Its numbers are [`ModeFields`] (built once,
/// by [`crate::linear::Mode::fields`], for this and the report's sidecar): a real
/// eigenvalue (a divergence, a non-oscillatory decay, a neutral direction) has `null`
/// ω_n, f and ζ, which would describe a frequency it does not have; a growing mode
/// (`growing`: divergent, or an oscillation with negative damping, which keeps its ω_n, f
/// and ζ < 0) has its growth rate Re λ and time constant 1/Re λ; a decaying real mode its
/// decay rate −λ and time constant.
#[derive(Debug, Clone, Serialize)]
pub struct ModeJson<'a> {
    #[serde(flatten)]
    pub fields: ModeFields,
    pub shape: Named<'a, C64>,
    pub normalized_to: &'a str,
    /// The mode's name (`[[modes]]`, or `mode k` by frequency): with [`ModesReport::named`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<&'a str>,
    /// Body → fraction of the mode's kinetic energy.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kinetic_energy_share: Option<&'a crate::linear::tracking::Shares>,
    /// Force element (and `constraint reactions`) → fraction of its strain energy.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strain_energy_share: Option<&'a crate::linear::tracking::Shares>,
}

/// An equilibrium's stability for JSON: `None` (`null`) when it has no degrees of
/// freedom (no ω²: the constraints, perhaps driven in time, fix every coordinate), where
/// "stable" would claim what nothing was tested for.
pub fn stability(e: &Equilibrium) -> Option<bool> {
    (!e.omega2.is_empty()).then_some(e.stable)
}

/// `modes --json`.
#[derive(Debug, Clone, Serialize)]
pub struct ModesReport<'a> {
    pub equilibrium: Named<'a, f64>,
    /// STATIC stability of the equilibrium: every undamped ω² of (K_r, M_r) positive (a
    /// minimum of the potential). `null` with no degrees of freedom (see [`stability`]).
    pub stable: Option<bool>,
    /// DYNAMIC stability: no mode grows (no Re λ above round-off,
    /// [`ModalAnalysis::growing`]). Negative damping makes a statically stable equilibrium
    /// dynamically unstable. `null` with no degrees of freedom.
    pub dynamically_stable: Option<bool>,
    /// The growing modes (`mode`: name, `growth_rate_1_s` = Re λ, `omega_d_rad_s`: 0 for
    /// a divergence), in the modes' order; empty when dynamically stable.
    pub growing_modes: Vec<crate::margins::UnstableMode>,
    pub modes: Vec<ModeJson<'a>>,
    pub undamped_omega2: &'a [f64],
    pub normalized_to: &'a str,
    pub provenance: &'a Provenance,
}

impl<'a> ModesReport<'a> {
    pub fn new(a: &'a ModalAnalysis, provenance: &'a Provenance) -> Self {
        ModesReport {
            equilibrium: Named::new(&a.coordinates, &a.equilibrium.q),
            stable: stability(&a.equilibrium),
            dynamically_stable: a.dynamically_stable(),
            growing_modes: crate::margins::unstable_modes(a, &[]),
            modes: a
                .modes
                .iter()
                .enumerate()
                .map(|(k, m)| ModeJson {
                    fields: a.fields(k),
                    shape: Named::new(&a.coordinates, &m.shape),
                    normalized_to: &a.coordinates[m.normalized_to],
                    name: None,
                    kinetic_energy_share: None,
                    strain_energy_share: None,
                })
                .collect(),
            undamped_omega2: &a.undamped_omega2,
            normalized_to: &a.coordinates[a.reference],
            provenance,
        }
    }

    /// [`ModesReport::new`] with each mode's name and energy shares (`named`: one per
    /// mode, from [`crate::linear::tracking::describe_modes`]).
    pub fn named(
        a: &'a ModalAnalysis,
        named: &'a [crate::linear::tracking::NamedMode],
        provenance: &'a Provenance,
    ) -> Self {
        let mut r = ModesReport::new(a, provenance);
        let names: Vec<String> = named.iter().map(|n| n.name.name.clone()).collect();
        r.growing_modes = crate::margins::unstable_modes(a, &names);
        for (m, n) in r.modes.iter_mut().zip(named) {
            m.name = Some(&n.name.name);
            m.kinetic_energy_share = Some(&n.energy.kinetic);
            m.strain_energy_share = Some(&n.energy.strain);
        }
        r
    }
}

/// `modes --param --json`: the tracking (values, per label ω_n, ζ, MAC; crossings,
/// veerings, least MACs) and the parameter's unit.
#[derive(Debug, Clone, Serialize)]
pub struct TrackingReport<'a> {
    pub tracking: &'a crate::linear::tracking::ModeTracking,
    /// The tracked parameter's declared unit (`""` when it has none).
    pub param_unit: &'a str,
    pub provenance: &'a Provenance,
}

/// `frf --json`: the equilibrium and one object per frequency, keyed like the CSV.
#[derive(Debug, Clone, Serialize)]
pub struct FrfReport<'a> {
    pub equilibrium: Named<'a, f64>,
    pub points: Vec<Map<String, Value>>,
    /// Maxima of the amplitudes, refined between grid points.
    pub peaks: &'a [crate::linear::LinearPeak],
    pub provenance: &'a Provenance,
}

impl<'a> FrfReport<'a> {
    pub fn new(fr: &'a FrequencyResponse, provenance: &'a Provenance) -> Self {
        let header = frf_header(fr);
        FrfReport {
            equilibrium: Named::new(&fr.coordinates, &fr.equilibrium.q),
            points: frf_rows(fr)
                .iter()
                .map(|row| row_object(&header, row))
                .collect(),
            peaks: &fr.peaks,
            provenance,
        }
    }
}

/// One equilibrium of a sweep's `equilibria` (a well): its index (a point's `well`),
/// its coordinates by name, its stability, ω² of M_r⁻¹ K_r (rad²/s²) and whether the
/// sweep (this run) starts from it.
#[derive(Debug, Clone, Serialize)]
pub struct WellJson<'a> {
    pub index: usize,
    pub coordinates: Named<'a, f64>,
    /// STATIC stability (a minimum of the potential: every ω² positive).
    pub stable: bool,
    /// DYNAMIC stability: no mode about it grows (as `equilibrium --json`'s); with negative
    /// damping a `stable` equilibrium is not dynamically stable. `null` where its modes
    /// could not be computed or it has no degrees of freedom.
    pub dynamically_stable: Option<bool>,
    pub omega2: &'a [f64],
    pub start: bool,
}

/// `sweep --json`: the equilibrium, the points (the CSV rows as objects, each with its
/// `well`), peaks (within one well), jumps, hysteresis, and every equilibrium a point's
/// `well` indexes; with `--values`, the equilibria of every run (a static load moves
/// them, `start` marks the one each run starts from), and every peak, jump, hysteresis
/// and equilibrium tagged with its run's value.
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport<'a> {
    pub equilibrium: Named<'a, f64>,
    pub points: Vec<Map<String, Value>>,
    pub peaks: Vec<Tagged<'a, &'a Peak>>,
    /// The responses whose peaks were not sought, and why (`kind`: `round_off`,
    /// `below_noise`, `unchanging`; `amplitude` the largest, `change` the largest less
    /// the smallest, `noise` the integration's, all in the response's unit).
    pub no_peaks: Vec<Tagged<'a, &'a crate::frequency::NoPeaks>>,
    pub jumps: Vec<Tagged<'a, &'a Jump>>,
    pub hysteresis: Vec<Tagged<'a, &'a Hysteresis>>,
    pub complete: bool,
    pub provenance: &'a Provenance,
    pub equilibria: Vec<Tagged<'a, WellJson<'a>>>,
    /// Where a sweep that failed stopped (absent when it did not fail): the failing
    /// frequency (rad/s), its direction, its stage (`coarse`, `back`: a jump check,
    /// `refine`), the reason, and with `--values` its run's values. `complete` is then
    /// false and the points are those finished before it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<Tagged<'a, FailureJson>>,
}

/// `failure` of `sweep --json`: see [`SweepReport::failure`].
#[derive(Debug, Clone, Serialize)]
pub struct FailureJson {
    pub omega: f64,
    pub direction: crate::frequency::Direction,
    pub stage: crate::frequency::checkpoint::CaseKind,
    pub message: String,
    /// What the sweep kept ([`crate::frequency::SweepFailure::kept`]).
    pub kept: &'static str,
}

impl<'a> SweepReport<'a> {
    pub fn new(runs: &'a [SweepRun], provenance: &'a Provenance) -> Self {
        let header = sweep_header(runs);
        let first = &runs[0].sweep;
        SweepReport {
            equilibrium: Named::new(&first.coordinates, &first.equilibrium),
            points: sweep_rows(runs)
                .iter()
                .map(|row| row_object(&header, row))
                .collect(),
            peaks: runs
                .iter()
                .flat_map(|r| {
                    r.sweep.peaks.iter().map(move |p| Tagged {
                        item: p,
                        tag: r.tags(),
                    })
                })
                .collect(),
            no_peaks: runs
                .iter()
                .flat_map(|r| {
                    r.sweep.no_peaks.iter().map(move |p| Tagged {
                        item: p,
                        tag: r.tags(),
                    })
                })
                .collect(),
            jumps: runs
                .iter()
                .flat_map(|r| {
                    r.sweep.jumps.iter().map(move |j| Tagged {
                        item: j,
                        tag: r.tags(),
                    })
                })
                .collect(),
            hysteresis: runs
                .iter()
                .flat_map(|r| {
                    r.sweep.hysteresis.iter().map(move |h| Tagged {
                        item: h,
                        tag: r.tags(),
                    })
                })
                .collect(),
            complete: runs.iter().all(|r| r.sweep.complete),
            failure: runs.iter().find_map(|r| {
                let f = r.sweep.failure.as_ref()?;
                Some(Tagged {
                    item: FailureJson {
                        omega: f.omega,
                        direction: f.direction,
                        stage: f.kind,
                        message: f.reason(),
                        kept: f.kept(),
                    },
                    tag: r.tags(),
                })
            }),
            provenance,
            equilibria: runs
                .iter()
                .flat_map(|r| {
                    let w = &r.sweep.wells;
                    w.equilibria.iter().enumerate().map(move |(k, e)| Tagged {
                        item: WellJson {
                            index: k,
                            coordinates: Named::new(&r.sweep.coordinates, &e.q),
                            stable: e.stable,
                            dynamically_stable: w.dynamically_stable.get(k).copied().flatten(),
                            omega2: &e.omega2,
                            start: k == w.start,
                        },
                        tag: r.tags(),
                    })
                })
                .collect(),
        }
    }
}
