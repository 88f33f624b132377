//! The report's sections, built from a model: the analyses are run once (the modes, the
//! linear frequency response), their results go into the sidecar as serializable
//! records, and the tables are keyed into those records.
//!
//! Stages, in order ([`build`]): provenance → model summary → pose drawing →
//! equilibrium → modes → linear frequency response → environment → interference
//! (Campbell) diagram.

use super::environment::Environment;
use super::figures::{Band, CampbellLine, CampbellPlot, FrfPlot, campbell_svg, frf_svg};
use super::{Cell, Column, Digits, Document, Report, Section, Sidecar, Table, escape_key};
use crate::check::CheckReport;
use crate::diag::{Error, Result};
use crate::linear::{C64, FrequencyResponse, LinearPeak, ModalAnalysis, Motion, modal_analysis};
use crate::model::Model;
use crate::model::units::Dim;
use crate::output::Provenance;
use crate::system::System;
use serde::Serialize;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// What the report is made from.
pub struct ReportInputs<'a> {
    /// The model file with its `--set` overrides.
    pub model: &'a Model,
    /// The compiled model, its `[trim]` solved.
    pub sys: &'a System,
    /// The vibration environment (forcing lines, rotor speeds), if any.
    pub environment: Option<&'a Environment>,
    /// Mode names and energy shares (mode tracking), if known.
    pub mode_extras: Option<&'a ModeExtras>,
    /// When the report is made, e.g. `2026-11-23T19:30:00Z` (the caller's clock: the
    /// library does not read one).
    pub generated_utc: String,
    /// The unit the page shows frequencies in (`--freq-unit`; rad/s beside them), the
    /// figures' frequency axes too. The sidecar stays in rad/s.
    pub freq_unit: crate::output::units::FreqUnit,
}

/// What mode tracking adds to the modes table, per mode in ω_n order.
#[derive(Debug, Clone, Default)]
pub struct ModeExtras {
    /// A name per mode (`stick pitch`), or None.
    pub names: Vec<Option<String>>,
    /// Per mode: the share of the modal kinetic energy of each body (0–1).
    pub energy_shares: Vec<Vec<(String, f64)>>,
}

impl ModeExtras {
    /// The names (the model's `[[modes]]`, else from mode tracking's description) and
    /// kinetic-energy shares of the modes of `sys` about its equilibrium; None where the
    /// modes cannot be described (the report then numbers them).
    pub fn of(sys: &crate::System) -> Option<ModeExtras> {
        let modal = crate::linear::modal_analysis(sys, None).ok()?;
        let described = crate::linear::tracking::describe_modes(sys, &modal).ok()?;
        Some(ModeExtras {
            names: described
                .iter()
                .map(|x| Some(x.name.name.clone()))
                .collect(),
            energy_shares: described
                .iter()
                .map(|x| x.energy.kinetic.0.clone())
                .collect(),
        })
    }
}

// ---- sidecar records ---------------------------------------------------------------

#[derive(Serialize)]
struct ProvenanceJson<'a> {
    #[serde(flatten)]
    provenance: &'a Provenance,
    model_name: &'a str,
    generated_utc: &'a str,
}

#[derive(Serialize)]
struct ParameterJson {
    name: String,
    /// SI value in `unit`.
    value: f64,
    unit: String,
    description: Option<String>,
    /// The `--set` that gave it.
    set: Option<String>,
}

#[derive(Serialize)]
struct BodyJson {
    name: String,
    coordinates: Vec<String>,
}

#[derive(Serialize)]
struct JointJson {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    /// Constraint rows, and the rank they add at the assembled pose.
    rows: Option<usize>,
    rank: Option<usize>,
}

#[derive(Serialize)]
struct ModelJson {
    name: String,
    description: Option<String>,
    spatial: bool,
    coordinates: usize,
    constraints: usize,
    /// Degrees of freedom at the assembled pose.
    dof: Option<usize>,
    bodies: Vec<BodyJson>,
    joints: Vec<JointJson>,
    forces: Vec<String>,
    parameters: Vec<ParameterJson>,
}

#[derive(Serialize)]
struct CoordinateJson {
    name: String,
    /// SI (m or rad).
    value: f64,
    unit: &'static str,
    /// Angles only.
    degrees: Option<f64>,
}

#[derive(Serialize)]
struct EquilibriumJson {
    /// STATIC stability (every undamped ω² positive); `null` with no degrees of freedom
    /// (as in `equilibrium --json`).
    stable: Option<bool>,
    /// DYNAMIC stability: no mode grows (as in `modes --json`); `null` with no degrees of
    /// freedom.
    dynamically_stable: Option<bool>,
    /// The growing modes (as in `modes --json`'s `growing_modes`).
    growing_modes: Vec<crate::margins::UnstableMode>,
    /// |R|∞ of the static equations.
    residual: f64,
    coordinates: Vec<CoordinateJson>,
    undamped_omega2: Vec<f64>,
}

#[derive(Serialize)]
struct ModeJson {
    mode: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    /// The numbers of `modes --json`'s modes, from the same constructor
    /// ([`crate::linear::Mode::fields`]): `null` ω_n, f and ζ for a real eigenvalue.
    #[serde(flatten)]
    fields: crate::linear::ModeFields,
    /// ω_n in rpm; `null` for a real eigenvalue, as ω_n.
    rpm: Option<f64>,
    /// By coordinate name, normalized to `normalized_to` = 1.
    shape: BTreeMap<String, C64>,
    normalized_to: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    energy_share: Option<BTreeMap<String, f64>>,
}

impl ModeJson {
    /// ω_n (rad/s), NaN for a divergent mode.
    fn omega_n(&self) -> f64 {
        self.fields.omega_n_rad_s.unwrap_or(f64::NAN)
    }

    /// The mode's name (the model's `[[modes]]`), or `mode N`.
    fn label(&self) -> String {
        self.name
            .clone()
            .unwrap_or_else(|| format!("mode {}", self.mode))
    }
}

#[derive(Serialize)]
struct ForcingJson {
    /// The amplitude parameter set for the response (the model's own is zero), SI.
    param: String,
    value: f64,
    unit: String,
}

#[derive(Serialize)]
struct ResponseJson {
    name: String,
    unit: String,
    amplitude: Vec<f64>,
    phase_deg: Vec<f64>,
}

#[derive(Serialize)]
struct PeakJson<'a> {
    #[serde(flatten)]
    peak: &'a LinearPeak,
    freq_hz: f64,
}

#[derive(Serialize)]
struct FrfJson<'a> {
    param: String,
    /// Set when the model's own forcing amplitude is zero: the response is per unit of
    /// this parameter.
    unit_forcing: Option<ForcingJson>,
    omega_rad_s: &'a [f64],
    responses: Vec<ResponseJson>,
    peaks: Vec<PeakJson<'a>>,
}

#[derive(Serialize)]
struct CrossingJson {
    mode: usize,
    /// The mode's name (`[[modes]]`), or `mode N`.
    mode_name: String,
    line: String,
    /// Speed of the diagram's rotor (the first) where the line meets the mode, rpm.
    rotor_rpm: f64,
    /// Of the nominal speed, %.
    percent_nominal: f64,
    omega_rad_s: f64,
    /// Null when the environment gives the rotor no operating range.
    in_operating_range: Option<bool>,
}

#[derive(Serialize)]
struct CampbellJson {
    rotor: String,
    /// Nominal speed of that rotor, rpm.
    rpm: f64,
    /// Its operating range, rpm, if the environment gives one.
    rpm_range: Option<[f64; 2]>,
    crossings: Vec<CrossingJson>,
}

// ---- helpers ------------------------------------------------------------------------

fn unit_of(sys: &System, i: usize) -> &'static str {
    if sys.is_angle(i) {
        "rad"
    } else if sys.coordinate_dims[i] == Dim::LENGTH {
        "m"
    } else {
        ""
    }
}

fn cols(list: &[(&str, &str)]) -> Vec<Column> {
    list.iter().map(|(t, u)| Column::new(*t, *u)).collect()
}

fn rpm(omega_rad_s: f64) -> f64 {
    omega_rad_s * 30.0 / PI
}

/// `n` frequencies log-spaced from `lo` to `hi` (rad/s).
pub fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    let (a, b) = (lo.ln(), hi.ln());
    (0..n)
        .map(|k| (a + (b - a) * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// The linear response over `values`: with the model as given, or, if its forcing is
/// zero, per unit of the first zero-valued parameter whose unit value makes a forcing
/// (a table amplitude `D0`, a force amplitude `F0`). Returns the response and that
/// parameter, or why there is none.
fn frf_with_forcing(
    model: &Model,
    sys: &System,
    values: &[f64],
    responses: &[String],
) -> std::result::Result<(FrequencyResponse, Option<ForcingJson>), String> {
    let Some(f) = sys.forcing_param() else {
        return Err("the model has no forcing frequency ([model] forcing_frequency)".into());
    };
    let param = sys.param_names()[f].clone();
    let first = match crate::linear::frequency_response(sys, &param, values, responses) {
        Ok(fr) => return Ok((fr, None)),
        Err(e) => e,
    };
    // the declared amplitude (`[model] forcing_amplitude`) first, then any zero-valued
    // parameter that makes a forcing
    let mut order: Vec<usize> = sys.forcing_amplitude_param().into_iter().collect();
    order
        .extend((0..sys.param_names().len()).filter(|&i| Some(i) != sys.forcing_amplitude_param()));
    for i in order {
        let name = &sys.param_names()[i];
        if i == f || sys.param(i) != 0.0 || sys.param_definition(i).is_some() {
            continue;
        }
        let Ok(unit_sys) = sys.with_param(i, 1.0) else {
            continue;
        };
        if let Ok(fr) = crate::linear::frequency_response(&unit_sys, &param, values, responses) {
            let unit = model.param_unit(name);
            return Ok((
                fr,
                Some(ForcingJson {
                    param: name.clone(),
                    value: 1.0,
                    unit,
                }),
            ));
        }
    }
    Err(first.to_string())
}

// ---- the report ------------------------------------------------------------------------

/// Run the analyses and build the report's document and sidecar.
pub fn build(inp: &ReportInputs) -> Result<Report> {
    let (model, sys) = (inp.model, inp.sys);
    let provenance = Provenance::of(model);
    let mut data = Sidecar::default();
    let mut sections = Vec::new();

    // provenance
    data.insert(
        "provenance",
        &ProvenanceJson {
            provenance: &provenance,
            model_name: &model.name,
            generated_utc: &inp.generated_utc,
        },
    )?;
    let overrides = if provenance.overrides.is_empty() {
        "none".to_string()
    } else {
        provenance.overrides.join(", ")
    };
    let about = Section::new("provenance", "Provenance").table(Table {
        caption: String::new(),
        columns: cols(&[("item", ""), ("value", "")]),
        rows: vec![
            vec![Cell::text("model"), data.text("provenance/model_name")],
            vec![Cell::text("model file"), data.text("provenance/model_file")],
            vec![
                Cell::text("model file SHA-256"),
                data.text("provenance/model_sha256"),
            ],
            vec![Cell::text("overrides (--set)"), Cell::text(overrides)],
            vec![
                Cell::text("detune version"),
                data.text("provenance/detune_version"),
            ],
            vec![
                Cell::text("generated (UTC)"),
                data.text("provenance/generated_utc"),
            ],
        ],
    });
    sections.push(about);

    // model summary
    let check = CheckReport::new(model, sys);
    let assembly = check.assembly.as_ref().ok();
    let model_json = ModelJson {
        name: model.name.clone(),
        description: model.description.clone(),
        spatial: model.spatial,
        coordinates: sys.n(),
        constraints: check.constraints.len(),
        dof: assembly.map(|a| a.dof),
        bodies: model
            .bodies
            .iter()
            .map(|b| BodyJson {
                name: b.name.clone(),
                coordinates: b.coords.clone(),
            })
            .collect(),
        joints: match assembly {
            Some(a) => a
                .elements
                .iter()
                .map(|e| JointJson {
                    name: e.name.clone(),
                    kind: e.kind.clone(),
                    rows: Some(e.rows),
                    rank: Some(e.rank),
                })
                .collect(),
            None => model
                .joints
                .iter()
                .map(|j| JointJson {
                    name: j.name.clone(),
                    kind: String::new(),
                    rows: None,
                    rank: None,
                })
                .collect(),
        },
        forces: sys.force_names.clone(),
        parameters: check
            .parameters
            .iter()
            .enumerate()
            .map(|(i, p)| ParameterJson {
                name: p.name.clone(),
                value: p.value,
                unit: p.unit.clone(),
                description: model.parameters.list[i].description.clone(),
                set: p.set.clone(),
            })
            .collect(),
    };
    data.insert("model", &model_json)?;
    let mut summary = Section::new("model", "Model")
        .prose(format!(
            "{} model: {} bodies, {} joints, {} force elements; {} coordinates, {} constraint equations.",
            if model.spatial { "Spatial" } else { "Planar" },
            model_json.bodies.len(),
            model_json.joints.len(),
            model_json.forces.len(),
            model_json.coordinates,
            model_json.constraints,
        ))
        .table(Table {
            caption: "Size".into(),
            columns: cols(&[("quantity", ""), ("count", "")]),
            rows: vec![
                vec![Cell::text("coordinates"), data.num("model/coordinates", Digits::Fixed(0))],
                vec![Cell::text("constraint equations"), data.num("model/constraints", Digits::Fixed(0))],
                vec![Cell::text("degrees of freedom"), data.num("model/dof", Digits::Fixed(0))],
            ],
        })
        .table(Table {
            caption: "Bodies".into(),
            columns: cols(&[("body", ""), ("coordinates", "")]),
            rows: model_json
                .bodies
                .iter()
                .map(|b| vec![Cell::text(&b.name), Cell::text(b.coordinates.join(", "))])
                .collect(),
        })
        .table(Table {
            caption: "Joints (rows and the rank they add at the assembled pose)".into(),
            columns: cols(&[("joint", ""), ("type", ""), ("rows", ""), ("rank added", "")]),
            rows: model_json
                .joints
                .iter()
                .enumerate()
                .map(|(k, j)| {
                    vec![
                        Cell::text(&j.name),
                        Cell::text(&j.kind),
                        data.num(format!("model/joints/{k}/rows"), Digits::Fixed(0)),
                        data.num(format!("model/joints/{k}/rank"), Digits::Fixed(0)),
                    ]
                })
                .collect(),
        });
    summary = summary.table(Table {
        caption: "Parameters (SI values; the unit each is shown in)".into(),
        columns: cols(&[
            ("parameter", ""),
            ("value", ""),
            ("unit", ""),
            ("description", ""),
            ("--set", ""),
        ]),
        rows: model_json
            .parameters
            .iter()
            .enumerate()
            .map(|(k, p)| {
                vec![
                    Cell::text(&p.name),
                    data.num(format!("model/parameters/{k}/value"), Digits::Sig(6)),
                    Cell::text(&p.unit),
                    Cell::text(p.description.clone().unwrap_or_default()),
                    Cell::text(p.set.clone().unwrap_or_default()),
                ]
            })
            .collect(),
    });
    sections.push(summary);

    // the pose drawing: the assembled initial pose, as `detune draw` draws it
    let start = crate::dynamics::assemble_at_rest(sys)?;
    let pose = crate::draw::scene(sys, &start.q)
        .name_forces(&sys.force_names)
        .svg(&model.name);
    sections.push(Section::new("pose", "Pose").figure(
        format!(
            "{}: the assembled initial pose, as detune draw draws it ({}; lengths in the axes' units).",
            model.name,
            if model.spatial {
                "front, side, top and isometric views"
            } else {
                "the X–Y plane"
            }
        ),
        pose,
    ));

    // the equilibrium and the modes about it
    let m: ModalAnalysis = modal_analysis(sys, None)?;
    let eq = EquilibriumJson {
        stable: crate::output::json::stability(&m.equilibrium),
        dynamically_stable: m.dynamically_stable(),
        growing_modes: crate::margins::unstable_modes(
            &m,
            &extras_names(inp.mode_extras, m.modes.len()),
        ),
        residual: m.equilibrium.residual,
        coordinates: m
            .coordinates
            .iter()
            .enumerate()
            .map(|(i, c)| CoordinateJson {
                name: c.clone(),
                value: m.equilibrium.q[i],
                unit: unit_of(sys, i),
                degrees: sys.is_angle(i).then(|| m.equilibrium.q[i].to_degrees()),
            })
            .collect(),
        undamped_omega2: m.undamped_omega2.clone(),
    };
    data.insert("equilibrium", &eq)?;
    sections.push(
        Section::new("equilibrium", "Equilibrium")
            .prose(format!(
                "The static equilibrium nearest the initial pose, loads at their mean over a period: {}. Static residual {} (N and m mixed).",
                match (eq.stable, eq.dynamically_stable) {
                    (None, _) => crate::linear::no_modes_words(sys),
                    (Some(true), Some(true)) => "stable (every undamped ω² positive, and no mode grows)".to_string(),
                    _ => crate::linear::stability_words(eq.stable, eq.dynamically_stable, &eq.growing_modes),
                },
                data.inline("equilibrium/residual", Digits::Sci(1))
            ))
            .table(Table {
                caption: "Coordinates at the equilibrium".into(),
                columns: cols(&[("coordinate", ""), ("value", ""), ("unit", ""), ("angle", "deg")]),
                rows: eq
                    .coordinates
                    .iter()
                    .enumerate()
                    .map(|(i, c)| {
                        vec![
                            Cell::text(&c.name),
                            data.num(format!("equilibrium/coordinates/{i}/value"), Digits::Fixed(6)),
                            Cell::text(c.unit),
                            if c.degrees.is_some() {
                                data.num(format!("equilibrium/coordinates/{i}/degrees"), Digits::Fixed(4))
                            } else {
                                Cell::text("")
                            },
                        ]
                    })
                    .collect(),
            }),
    );

    // modes
    let extras = inp.mode_extras;
    let modes: Vec<ModeJson> = m
        .modes
        .iter()
        .enumerate()
        .map(|(k, md)| {
            let fields = m.fields(k);
            ModeJson {
                mode: k + 1,
                name: extras.and_then(|x| x.names.get(k).cloned().flatten()),
                rpm: fields.omega_n_rad_s.map(rpm),
                fields,
                shape: m
                    .coordinates
                    .iter()
                    .cloned()
                    .zip(md.shape.iter().copied())
                    .collect(),
                normalized_to: m.coordinates[md.normalized_to].clone(),
                energy_share: extras
                    .and_then(|x| x.energy_shares.get(k))
                    .map(|s| s.iter().cloned().collect()),
            }
        })
        .collect();
    data.insert("modes", &modes)?;
    let named = modes.iter().any(|x| x.name.is_some());
    let mut head = vec![("mode", "")];
    if named {
        head.push(("name", ""));
    }
    head.extend([
        ("ω_n", "rad/s"),
        ("f_n", "Hz"),
        ("f_n", "rpm"),
        ("ζ", ""),
        ("ω_d", "rad/s"),
    ]);
    let mut modes_section = Section::new("modes", "Modes")
        .prose(format!(
            "Modes of the linearized constrained dynamics about the equilibrium ({} degrees of freedom). Shapes are normalized to {} = 1; a complex entry is a phase lag against it (damping).",
            m.linearization.dof(),
            m.coordinates[m.reference]
        ))
        .table(Table {
            caption: "Natural frequencies and damping".into(),
            columns: cols(&head),
            rows: modes
                .iter()
                .enumerate()
                .map(|(k, x)| {
                    let mut row = vec![Cell::text(format!("{}", x.mode))];
                    if named {
                        row.push(Cell::text(x.name.clone().unwrap_or_default()));
                    }
                    if x.fields.non_oscillatory {
                        // a real eigenvalue: no frequency or damping ratio (as `modes` says)
                        let what = match x.fields.motion {
                            Motion::Divergent => format!(
                                "divergent: grows as e^(+{} t) (1/s), time constant {} s",
                                data.inline(
                                    format!("modes/{k}/growth_rate_1_s"),
                                    rate_digits(x.fields.growth_rate_1_s)
                                ),
                                data.inline(format!("modes/{k}/time_constant_s"), Digits::Fixed(4)),
                            ),
                            Motion::Decaying => format!(
                                "non-oscillatory: decays as e^(−{} t) (1/s), time constant {} s",
                                data.inline(format!("modes/{k}/decay_rate_1_s"), Digits::Fixed(3)),
                                data.inline(
                                    format!("modes/{k}/decay_time_constant_s"),
                                    Digits::Fixed(4)
                                ),
                            ),
                            _ => "non-oscillatory: neutral (λ = 0 to round-off)".to_string(),
                        };
                        row.extend([
                            Cell::text(what),
                            Cell::text("—"),
                            Cell::text("—"),
                            Cell::text("—"),
                            data.num(format!("modes/{k}/omega_d_rad_s"), Digits::Fixed(3)),
                        ]);
                        return row;
                    }
                    // a growing oscillation: ζ < 0, and the growth said beside it
                    let zeta = if x.fields.motion == Motion::GrowingOscillation {
                        Cell::text(format!(
                            "{} (growing: e^(+{} t), 1/s)",
                            data.inline(format!("modes/{k}/damping_ratio"), Digits::Fixed(4)),
                            data.inline(
                                format!("modes/{k}/growth_rate_1_s"),
                                rate_digits(x.fields.growth_rate_1_s)
                            ),
                        ))
                    } else {
                        data.num(format!("modes/{k}/damping_ratio"), Digits::Fixed(4))
                    };
                    row.extend([
                        data.num(format!("modes/{k}/omega_n_rad_s"), Digits::Fixed(3)),
                        data.num(format!("modes/{k}/freq_hz"), Digits::Fixed(4)),
                        data.num(format!("modes/{k}/rpm"), Digits::Fixed(1)),
                        zeta,
                        data.num(format!("modes/{k}/omega_d_rad_s"), Digits::Fixed(3)),
                    ]);
                    row
                })
                .collect(),
        });
    if !modes.is_empty() {
        let mut head: Vec<Column> = vec![Column::new("coordinate", "")];
        for x in &modes {
            head.push(Column::new(format!("{} re", x.label()), ""));
            head.push(Column::new(format!("{} im", x.label()), ""));
        }
        modes_section = modes_section.table(Table {
            caption: "Mode shapes by coordinate (unit: the coordinate's per unit of the reference)"
                .into(),
            columns: head,
            rows: m
                .coordinates
                .iter()
                .map(|c| {
                    let mut row = vec![Cell::text(c)];
                    let c = escape_key(c);
                    for k in 0..modes.len() {
                        row.push(data.num(format!("modes/{k}/shape/{c}/re"), Digits::Fixed(4)));
                        row.push(data.num(format!("modes/{k}/shape/{c}/im"), Digits::Fixed(4)));
                    }
                    row
                })
                .collect(),
        });
    }
    if let Some(x) = extras.filter(|x| !x.energy_shares.is_empty()) {
        let bodies: Vec<String> = x
            .energy_shares
            .iter()
            .flat_map(|s| s.iter().map(|(b, _)| b.clone()))
            .fold(Vec::new(), |mut v, b| {
                if !v.contains(&b) {
                    v.push(b);
                }
                v
            });
        let mut head = vec![Column::new("body", "")];
        head.extend(
            modes
                .iter()
                .map(|x| Column::new(x.label(), "share of kinetic energy")),
        );
        modes_section = modes_section.table(Table {
            caption: "Energy share per body".into(),
            columns: head,
            rows: bodies
                .iter()
                .map(|b| {
                    let mut row = vec![Cell::text(b)];
                    let b = escape_key(b);
                    for k in 0..modes.len() {
                        row.push(data.num(format!("modes/{k}/energy_share/{b}"), Digits::Fixed(3)));
                    }
                    row
                })
                .collect(),
        });
    }
    sections.push(modes_section);

    // linear frequency response
    let oscillating: Vec<(usize, f64)> = modes
        .iter()
        .enumerate()
        .filter(|(_, x)| x.fields.omega_d_rad_s > 0.0 && x.omega_n().is_finite())
        .map(|(k, x)| (k, x.omega_n()))
        .collect();
    let mut frf_section = Section::new("frf", "Linear frequency response");
    if let (Some(lo), Some(hi)) = (
        oscillating.iter().map(|x| x.1).reduce(f64::min),
        oscillating.iter().map(|x| x.1).reduce(f64::max),
    ) {
        let values = log_grid(0.2 * lo, 2.5 * hi, FRF_POINTS);
        // the coordinates some oscillating mode moves (a coordinate the constraints hold,
        // a slider's angle, would plot a line of zeros); the angles among them, else all
        let moves = |i: usize| {
            oscillating
                .iter()
                .any(|&(k, _)| m.modes[k].shape.get(i).is_some_and(|z| z.norm() > 1e-9))
        };
        let moving: Vec<usize> = (0..sys.n()).filter(|&i| moves(i)).collect();
        let angles: Vec<String> = moving
            .iter()
            .filter(|&&i| sys.is_angle(i))
            .map(|&i| sys.coordinates[i].clone())
            .collect();
        let responses = if !angles.is_empty() {
            angles
        } else if !moving.is_empty() {
            moving.iter().map(|&i| sys.coordinates[i].clone()).collect()
        } else {
            sys.coordinates.clone()
        };
        match frf_with_forcing(model, sys, &values, &responses) {
            Ok((fr, unit_forcing)) => {
                let per = unit_forcing
                    .as_ref()
                    .map(|f| {
                        if f.unit.is_empty() {
                            String::new()
                        } else {
                            format!("/{}", f.unit)
                        }
                    })
                    .unwrap_or_default();
                let frf = FrfJson {
                    param: fr.param.clone(),
                    unit_forcing,
                    omega_rad_s: &fr.omega,
                    responses: fr
                        .responses
                        .iter()
                        .enumerate()
                        .map(|(r, name)| ResponseJson {
                            name: name.clone(),
                            unit: format!(
                                "{}{per}",
                                sys.coordinate_index(name)
                                    .map(|i| unit_of(sys, i))
                                    .unwrap_or("")
                            ),
                            amplitude: fr.values.iter().map(|row| row[r].0).collect(),
                            phase_deg: fr.values.iter().map(|row| row[r].1).collect(),
                        })
                        .collect(),
                    peaks: fr
                        .peaks
                        .iter()
                        .map(|p| PeakJson {
                            peak: p,
                            freq_hz: p.omega / (2.0 * PI),
                        })
                        .collect(),
                };
                let unit = frf
                    .responses
                    .first()
                    .map(|r| r.unit.clone())
                    .unwrap_or_default();
                data.insert("frf", &frf)?;
                let forcing_text = match &frf.unit_forcing {
                    Some(f) => format!(
                        "The model's forcing amplitude is zero, so the response is per unit of {} ({} = {} {}): amplitudes in {unit}.",
                        f.param,
                        f.param,
                        data.inline("frf/unit_forcing/value", Digits::Sig(3)),
                        f.unit
                    ),
                    None => format!("The model's own forcing amplitude; amplitudes in {unit}."),
                };
                let bands: Vec<Band> = inp
                    .environment
                    .map(|e| {
                        e.lines
                            .iter()
                            .map(|l| Band {
                                label: l.label.clone(),
                                lo: l.band_lo_rad_s,
                                nominal: l.omega_rad_s,
                                hi: l.band_hi_rad_s,
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                let plot = FrfPlot {
                    title: format!("{}: linear response to {}", model.name, fr.param),
                    omega: fr.omega.clone(),
                    curves: frf
                        .responses
                        .iter()
                        .map(|r| (r.name.clone(), r.amplitude.clone()))
                        .collect(),
                    unit: unit.clone(),
                    resonances: oscillating
                        .iter()
                        .map(|(k, w)| (modes[*k].label(), *w))
                        .collect(),
                    peaks: fr.peaks.iter().map(|p| (p.omega, p.amplitude)).collect(),
                    bands,
                    freq_unit: inp.freq_unit,
                };
                let svg = frf_svg(&plot)
                    .map_err(|e| Error::io("report.html", format!("FRF figure: {e}")))?;
                frf_section = frf_section
                    .prose(format!(
                        "Steady harmonic response of the linearized model to its forcing ({}), {} log-spaced frequencies from {} to {} rad/s (from a fifth of the lowest to two and a half times the highest natural frequency); peaks refined between grid points. {forcing_text}{}",
                        fr.param,
                        fr.omega.len(),
                        data.inline("frf/omega_rad_s/0", Digits::Fixed(3)),
                        data.inline(format!("frf/omega_rad_s/{}", fr.omega.len() - 1), Digits::Fixed(3)),
                        if inp.environment.is_some() {
                            " Shaded: the forcing lines' bands over the rotors' operating range."
                        } else {
                            ""
                        }
                    ))
                    .figure(
                        "Amplitude against forcing frequency (log–log); dashed: the modes' ω_n; triangles: refined peaks; shaded: forcing bands.",
                        svg,
                    )
                    .table(Table {
                        caption: "Resonance peaks".into(),
                        columns: cols(&[("response", ""), ("ω", "rad/s"), ("f", "Hz"), ("amplitude", &unit)]),
                        rows: frf
                            .peaks
                            .iter()
                            .enumerate()
                            .map(|(k, p)| {
                                vec![
                                    Cell::text(&p.peak.response),
                                    data.num(format!("frf/peaks/{k}/omega"), Digits::Fixed(3)),
                                    data.num(format!("frf/peaks/{k}/freq_hz"), Digits::Fixed(4)),
                                    data.num(format!("frf/peaks/{k}/amplitude"), Digits::Sig(4)),
                                ]
                            })
                            .collect(),
                    });
            }
            Err(why) => {
                frf_section = frf_section.prose(format!("No linear response: {why}"));
            }
        }
    } else {
        frf_section = frf_section.prose("No oscillating mode: no frequency response to show.");
    }
    sections.push(frf_section);

    // environment and interference diagram
    if let Some(env) = inp.environment {
        data.insert("environment", env)?;
        let source = keyed_source(&env.source, &mut data);
        sections.push(environment_section(env, &data, &source));
        sections.push(campbell(env, &modes, &mut data, inp.freq_unit)?);
    } else {
        sections.push(Section::new("campbell", "Interference diagram").prose(
            "No vibration environment given: run with --environment (e.g. UH-60) for the forcing lines and the interference diagram.",
        ));
    }

    Ok(Report {
        document: Document {
            title: format!("{}: design review", model.name),
            subtitle: format!(
                "{} — detune {} — {}",
                model.description.clone().unwrap_or_default(),
                provenance.detune_version,
                inp.generated_utc
            ),
            warnings: Vec::new(),
            sections,
        },
        sidecar: data,
    })
}

/// Frequencies of the report's linear response grid.
pub const FRF_POINTS: usize = 400;

/// The environment's `source` text with each number it writes in rad/s keyed into the
/// sidecar (`environment/source_rad_s/<k>`, as written), so that the page shows it in
/// the `--freq-unit` with rad/s beside it, like the computed numbers.
fn keyed_source(source: &str, data: &mut Sidecar) -> String {
    let found = crate::output::units::rad_s_in_text(source);
    if found.is_empty() {
        return source.to_string();
    }
    if let Some(serde_json::Value::Object(env)) = data.0.get_mut("environment") {
        env.insert(
            "source_rad_s".into(),
            serde_json::Value::from(found.iter().map(|f| f.1).collect::<Vec<f64>>()),
        );
    } else {
        return source.to_string();
    }
    let mut out = String::new();
    let mut last = 0;
    for (k, (range, _, decimals)) in found.into_iter().enumerate() {
        out.push_str(&source[last..range.start]);
        out.push_str(&data.inline(
            format!("environment/source_rad_s/{k}"),
            Digits::Fixed(decimals),
        ));
        last = range.end;
    }
    out.push_str(&source[last..]);
    out
}

fn environment_section(env: &Environment, data: &Sidecar, source: &str) -> Section {
    Section::new("environment", &format!("Environment: {}", env.name))
        .prose(format!("Forcing lines of the {} ({source}).", env.name))
        .table(Table {
            caption: "Rotors".into(),
            columns: cols(&[
                ("rotor", ""),
                ("blades", ""),
                ("nominal", "rpm"),
                ("range low", "rpm"),
                ("range high", "rpm"),
            ]),
            rows: env
                .rotors
                .iter()
                .enumerate()
                .map(|(k, r)| {
                    let mut row = vec![
                        data.text(&format!("environment/rotors/{k}/name")),
                        data.num(format!("environment/rotors/{k}/blades"), Digits::Fixed(0)),
                        data.num(format!("environment/rotors/{k}/rpm"), Digits::Fixed(1)),
                    ];
                    if r.rpm_range.is_some() {
                        row.extend((0..2).map(|i| {
                            data.num(
                                format!("environment/rotors/{k}/rpm_range/{i}"),
                                Digits::Fixed(1),
                            )
                        }));
                    } else {
                        row.extend([Cell::text("none given"), Cell::text("none given")]);
                    }
                    row
                })
                .collect(),
        })
        .table(Table {
            caption: "Forcing lines and their bands over the operating range (a line without a range is a point)".into(),
            columns: cols(&[
                ("line", ""),
                ("rotor", ""),
                ("multiple", "× rotor speed"),
                ("ω nominal", "rad/s"),
                ("band low", "rad/s"),
                ("band high", "rad/s"),
            ]),
            rows: env
                .lines
                .iter()
                .enumerate()
                .map(|(k, l)| {
                    vec![
                        data.text(&format!("environment/lines/{k}/label")),
                        Cell::text(l.rotor.clone().unwrap_or_else(|| "fixed".into())),
                        if l.multiple.is_some() {
                            data.num(format!("environment/lines/{k}/multiple"), Digits::Fixed(0))
                        } else {
                            Cell::text("")
                        },
                        data.num(
                            format!("environment/lines/{k}/omega_rad_s"),
                            Digits::Fixed(2),
                        ),
                        data.num(
                            format!("environment/lines/{k}/band_lo_rad_s"),
                            Digits::Fixed(2),
                        ),
                        data.num(
                            format!("environment/lines/{k}/band_hi_rad_s"),
                            Digits::Fixed(2),
                        ),
                    ]
                })
                .collect(),
        })
}

/// The interference diagram: each oscillating mode's ω_n against every rotor line, the
/// speed axis that of the environment's first rotor (the others geared to it); fixed
/// lines and bands (no rotor) do not move with the speed and are left to the response
/// figure and the margins.
fn campbell(
    env: &Environment,
    modes: &[ModeJson],
    data: &mut Sidecar,
    freq_unit: crate::output::units::FreqUnit,
) -> Result<Section> {
    let Some(main) = env.rotors.first() else {
        return Ok(
            Section::new("campbell", "Interference diagram").prose("The environment has no rotor.")
        );
    };
    let [_, rpm_hi] = main.rpm_bounds();
    let rpm_end = 1.2 * rpm_hi;
    // ω of each line per main-rotor rpm
    let lines: Vec<CampbellLine> = env
        .lines
        .iter()
        .filter_map(|l| {
            let r = env.rotor(l)?;
            Some(CampbellLine {
                label: l.label.clone(),
                slope: l.multiple? * (r.rpm / main.rpm) * PI / 30.0,
            })
        })
        .filter(|l| l.slope > 0.0 && l.slope.is_finite())
        .collect();
    let osc: Vec<&ModeJson> = modes
        .iter()
        .filter(|m| m.fields.omega_d_rad_s > 0.0)
        .collect();
    let mut crossings = Vec::new();
    for m in &osc {
        for l in &lines {
            let at = m.omega_n() / l.slope;
            if at > 0.0 && at <= rpm_end {
                crossings.push(CrossingJson {
                    mode: m.mode,
                    mode_name: m.label(),
                    line: l.label.clone(),
                    rotor_rpm: at,
                    percent_nominal: 100.0 * at / main.rpm,
                    omega_rad_s: m.omega_n(),
                    in_operating_range: main.rpm_range.map(|[lo, hi]| at >= lo && at <= hi),
                });
            }
        }
    }
    let wmax = osc.iter().map(|m| m.omega_n()).fold(0.0, f64::max);
    let lowest_line = lines
        .iter()
        .map(|l| l.slope * main.rpm)
        .fold(f64::INFINITY, f64::min);
    let omega_end = 1.3
        * wmax
            .max(if lowest_line.is_finite() {
                lowest_line
            } else {
                0.0
            })
            .max(1e-6);
    let plot = CampbellPlot {
        title: format!("Interference diagram ({})", env.name),
        rotor: main.name.clone(),
        rpm_nominal: main.rpm,
        rpm_range: main.rpm_range,
        modes: osc.iter().map(|m| (m.label(), m.omega_n())).collect(),
        lines,
        crossings: crossings
            .iter()
            .map(|c| {
                (
                    c.rotor_rpm,
                    c.omega_rad_s,
                    c.in_operating_range == Some(true),
                )
            })
            .collect(),
        rpm_end,
        omega_end,
        freq_unit,
    };
    let svg = campbell_svg(&plot)
        .map_err(|e| Error::io("report.html", format!("Campbell figure: {e}")))?;
    let json = CampbellJson {
        rotor: main.name.clone(),
        rpm: main.rpm,
        rpm_range: main.rpm_range,
        crossings,
    };
    data.insert("campbell", &json)?;
    let nearest = json
        .crossings
        .iter()
        .enumerate()
        .min_by(|(_, a), (_, b)| {
            (a.percent_nominal - 100.0)
                .abs()
                .total_cmp(&(b.percent_nominal - 100.0).abs())
        })
        .map(|(i, c)| {
            format!(
                " The crossing nearest the nominal speed: {} with {} at {} rpm ({} % of nominal).",
                c.mode_name,
                c.line,
                data.inline(
                    format!("campbell/crossings/{i}/rotor_rpm"),
                    Digits::Fixed(1)
                ),
                data.inline(
                    format!("campbell/crossings/{i}/percent_nominal"),
                    Digits::Fixed(1)
                ),
            )
        })
        .unwrap_or_default();
    let any_range = json
        .crossings
        .iter()
        .any(|c| c.in_operating_range.is_some());
    let range = match main.rpm_range {
        Some(_) => format!(
            "{} of {} crossings fall inside the operating range {}–{} rpm (filled circles).",
            json.crossings
                .iter()
                .filter(|c| c.in_operating_range == Some(true))
                .count(),
            json.crossings.len(),
            data.inline("campbell/rpm_range/0", Digits::Fixed(1)),
            data.inline("campbell/rpm_range/1", Digits::Fixed(1)),
        ),
        None => format!(
            "The environment gives the {} rotor no operating range: the vertical line is its nominal {} rpm, and no crossing is judged in or out of range.",
            main.name,
            data.inline("campbell/rpm", Digits::Fixed(1))
        ),
    };
    let geared = env
        .rotors
        .iter()
        .skip(1)
        .map(|r| r.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let section = Section::new("campbell", "Interference diagram")
        .prose(format!(
            "Mode frequencies against the {} rotor's speed, with the rotor lines through the origin{}. {range}{nearest}",
            main.name,
            if geared.is_empty() {
                String::new()
            } else {
                format!(" (the {geared} rotor's lines geared to it)")
            },
        ))
        .figure("Campbell-style interference diagram: dashed, the modes' ω_n; orange, the n/rev lines and the nominal speed; shaded, the operating range (when given); circles, crossings (filled inside the operating range).", svg)
        .table(Table {
            caption: "Crossings of the modes with the rotor lines".into(),
            // the in-range column only where the environment gives a range (the prose says
            // when it does not)
            columns: cols(
                &[
                    ("mode", ""),
                    ("line", ""),
                    ("rotor speed", "rpm"),
                    ("of nominal", "%"),
                    ("ω", "rad/s"),
                    ("in operating range", ""),
                ][..if any_range { 6 } else { 5 }],
            ),
            rows: json
                .crossings
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    let mut row = vec![
                        Cell::text(c.mode_name.clone()),
                        Cell::text(&c.line),
                        data.num(format!("campbell/crossings/{k}/rotor_rpm"), Digits::Fixed(1)),
                        data.num(format!("campbell/crossings/{k}/percent_nominal"), Digits::Fixed(1)),
                        data.num(format!("campbell/crossings/{k}/omega_rad_s"), Digits::Fixed(3)),
                    ];
                    if any_range {
                        row.push(Cell::text(match c.in_operating_range {
                            Some(true) => "YES",
                            Some(false) => "no",
                            None => "no range given",
                        }));
                    }
                    row
                })
                .collect(),
        });
    Ok(section)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_names_and_energy_shares_plug_into_the_modes_section() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/overcentre.toml");
        let model = Model::load(path).unwrap();
        let sys = System::new(&model).unwrap();
        let extras = ModeExtras {
            names: vec![Some("bar swing".into())],
            energy_shares: vec![vec![("bar1".into(), 0.25), ("bar2".into(), 0.75)]],
        };
        let r = build(&ReportInputs {
            model: &model,
            sys: &sys,
            environment: None,
            mode_extras: Some(&extras),
            generated_utc: "2026-11-23T00:00:00Z".into(),
            freq_unit: Default::default(),
        })
        .unwrap();
        assert_eq!(r.sidecar.get("modes/0/name").unwrap(), "bar swing");
        assert_eq!(r.sidecar.get("modes/0/energy_share/bar2").unwrap(), 0.75);
        let page = r.document.html();
        assert!(page.contains("<td>bar swing</td>"));
        assert!(page.contains(r#"data-key="modes/0/energy_share/bar1">0.250<"#));
    }

    #[test]
    fn crossings_inside_an_operating_range_are_flagged() {
        use crate::report::{Environment, Rotor};
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/inceptor.toml");
        let model = Model::load(path).unwrap();
        let sys = crate::statics::trim::trim(&System::new(&model).unwrap())
            .unwrap()
            .0;
        // a 258 rpm rotor run at 95–101 %: mode 2 (26.531 rad/s) meets 1P at
        // 30·26.531/π = 253.35 rpm, inside; 4P at 63.3 rpm, outside
        let env = Environment::with_lines(
            "test",
            "a made-up range",
            vec![Rotor {
                name: "main".into(),
                blades: 4,
                rpm: 258.0,
                rpm_range: Some([0.95 * 258.0, 1.01 * 258.0]),
            }],
            &[("main", 1.0, "1P"), ("main", 4.0, "4P")],
        );
        let r = build(&ReportInputs {
            model: &model,
            sys: &sys,
            environment: Some(&env),
            mode_extras: None,
            generated_utc: String::new(),
            freq_unit: Default::default(),
        })
        .unwrap();
        let c = r
            .sidecar
            .get("campbell/crossings")
            .unwrap()
            .as_array()
            .unwrap();
        let w2 = r
            .sidecar
            .get("modes/1/omega_n_rad_s")
            .unwrap()
            .as_f64()
            .unwrap();
        for x in c {
            let rpm = x["rotor_rpm"].as_f64().unwrap();
            let inside = (0.95 * 258.0..=1.01 * 258.0).contains(&rpm);
            assert_eq!(x["in_operating_range"], inside);
        }
        let one_p = c
            .iter()
            .find(|x| x["mode"] == 2 && x["line"] == "1P")
            .unwrap();
        assert!((one_p["rotor_rpm"].as_f64().unwrap() - 30.0 * w2 / PI).abs() < 1e-9);
        assert_eq!(one_p["in_operating_range"], true);
        // the 1P band is [245.1, 260.58] rpm × π/30
        let band = r.sidecar.get("environment/lines/0").unwrap();
        assert!((band["band_lo_rad_s"].as_f64().unwrap() - 0.95 * 258.0 * PI / 30.0).abs() < 1e-12);
        assert!(
            r.document
                .html()
                .contains("1 of 4 crossings fall inside the operating range")
        );
    }

    #[test]
    fn log_grid_ends_where_asked() {
        let g = log_grid(2.0, 200.0, 3);
        assert!((g[0] - 2.0).abs() < 1e-12 && (g[1] - 20.0).abs() < 1e-12);
        assert!((g[2] - 200.0).abs() < 1e-10);
    }
}

/// The modes' names for the report (the model's `[[modes]]` where given, else `mode k`).
fn extras_names(extras: Option<&ModeExtras>, n: usize) -> Vec<String> {
    (0..n)
        .map(|k| {
            extras
                .and_then(|x| x.names.get(k).cloned().flatten())
                .unwrap_or_else(|| format!("mode {}", k + 1))
        })
        .collect()
}

/// The digits of a growth rate (1/s) on the page: 3 decimals, or 4 significant digits
/// below 1e-3 (a slow growth is not shown as 0.000; [`crate::linear::rate_text`]).
fn rate_digits(rate: Option<f64>) -> Digits {
    match rate {
        Some(r) if r.abs() < 1e-3 => Digits::Sig(4),
        _ => Digits::Fixed(3),
    }
}
