//! CSV and JSON layouts of the analyses' results (pure functions of result structs).

use super::{Provenance, num, write_atomic};
use crate::diag::Result;
use crate::dynamics::simulate::{SimOptions, Trajectory};
use crate::frequency::study::SweepRun;
use crate::linear::{FrequencyResponse, ModalAnalysis};
use crate::statics::Equilibrium;
use crate::statics::continuation::{Branch, BranchPoint};
use serde_json::{Map, Value, json};

/// `{name: value}` of coordinates.
pub fn coordinates_json(names: &[String], q: &[f64]) -> Value {
    Value::Object(
        names
            .iter()
            .zip(q)
            .map(|(n, v)| (n.clone(), json!(v)))
            .collect::<Map<String, Value>>(),
    )
}

/// The `simulate` JSON summary: provenance, options, step statistics, the final state
/// and the CSV written (`output`).
pub fn simulation_json(
    provenance: &Provenance,
    opts: &SimOptions,
    traj: &Trajectory,
    output: &str,
) -> Value {
    let last = traj.q.len() - 1;
    json!({
        "provenance": provenance,
        "options": {"t_end": opts.t_end, "dt_out": opts.dt_out, "rtol": opts.rtol, "atol": opts.atol},
        "stats": traj.stats,
        "final": {"t": traj.t[last], "coordinates": coordinates_json(&traj.coordinates, &traj.q[last])},
        "output": output,
    })
}

/// `{"coordinates": {...}, "stable": bool, "residual": x, "omega2": [...]}`.
pub fn equilibrium_json(names: &[String], e: &Equilibrium) -> Value {
    json!({
        "coordinates": coordinates_json(names, &e.q),
        "stable": e.stable,
        "residual": e.residual,
        "iterations": e.iterations,
        "undamped_omega2": e.omega2,
    })
}

/// A fold or branch point: no `stable` flag, since the stiffness is singular there (the
/// point is marginal; stability changes across it).
fn branch_point_json(names: &[String], p: &BranchPoint) -> Value {
    json!({"value": p.value, "coordinates": coordinates_json(names, &p.q)})
}

/// `{"param", "folds": [...], "branch_points": [...], "points": n, "truncated"}`.
pub fn branch_json(b: &Branch, provenance: &Provenance) -> Value {
    json!({
        "param": b.param,
        "folds": b.folds.iter().map(|p| branch_point_json(&b.coordinates, p)).collect::<Vec<_>>(),
        "branch_points": b.branch_points.iter().map(|p| branch_point_json(&b.coordinates, p)).collect::<Vec<_>>(),
        "points": b.points.len(),
        "truncated": b.truncated,
        "provenance": provenance,
    })
}

/// CSV of a branch: `<param>,<coordinates>...,stable`.
pub fn write_branch_csv(path: &str, b: &Branch) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{},{},stable", b.param, b.coordinates.join(","))?;
        for p in &b.points {
            write!(w, "{}", num(p.value))?;
            for x in &p.q {
                write!(w, ",{}", num(*x))?;
            }
            writeln!(w, ",{}", u8::from(p.stable))?;
        }
        Ok(())
    })
}

/// The `modes` JSON.
pub fn modes_json(a: &ModalAnalysis, provenance: &Provenance) -> Value {
    let modes: Vec<Value> = a
        .modes
        .iter()
        .map(|m| {
            let shape: Map<String, Value> = a
                .coordinates
                .iter()
                .zip(&m.shape)
                .map(|(n, c)| (n.clone(), json!({"re": c.re, "im": c.im})))
                .collect();
            json!({
                "omega_n_rad_s": m.omega_n_rad_s,
                "omega_d_rad_s": m.omega_d_rad_s,
                "freq_hz": m.freq_hz,
                "damping_ratio": m.damping_ratio,
                "eigenvalue": {"re": m.eigenvalue.re, "im": m.eigenvalue.im},
                "shape": shape,
                "normalized_to": a.coordinates[m.normalized_to],
            })
        })
        .collect();
    json!({
        "equilibrium": coordinates_json(&a.coordinates, &a.equilibrium.q),
        "stable": a.equilibrium.stable,
        "modes": modes,
        "undamped_omega2": a.undamped_omega2,
        "normalized_to": a.coordinates[a.reference],
        "provenance": provenance,
    })
}

/// CSV of a linear frequency response: `<param>,<name>_amplitude,<name>_phase_deg,...`.
pub fn write_frf_csv(path: &str, fr: &FrequencyResponse) -> Result<()> {
    write_atomic(path, |w| {
        let mut header = vec![fr.param.clone()];
        for r in &fr.responses {
            header.push(format!("{r}_amplitude"));
            header.push(format!("{r}_phase_deg"));
        }
        writeln!(w, "{}", header.join(","))?;
        for (k, om) in fr.omega.iter().enumerate() {
            write!(w, "{}", num(*om))?;
            for (a, p) in &fr.values[k] {
                write!(w, ",{},{}", num(*a), num(*p))?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

/// JSON of a linear frequency response.
pub fn frf_json(fr: &FrequencyResponse, provenance: &Provenance) -> Value {
    let points: Vec<Value> = fr
        .omega
        .iter()
        .zip(&fr.values)
        .map(|(om, vals)| {
            let mut o = Map::new();
            o.insert(fr.param.clone(), json!(om));
            for (r, (a, p)) in fr.responses.iter().zip(vals) {
                o.insert(format!("{r}_amplitude"), json!(a));
                o.insert(format!("{r}_phase_deg"), json!(p));
            }
            Value::Object(o)
        })
        .collect();
    json!({
        "equilibrium": coordinates_json(&fr.coordinates, &fr.equilibrium.q),
        "points": points,
        "provenance": provenance,
    })
}

const MEASURES: [&str; 8] = [
    "amplitude",
    "max",
    "min",
    "mean",
    "h1",
    "phase_deg",
    "h2",
    "thd",
];

fn measure_values(m: &crate::frequency::measure::Measures) -> [f64; 8] {
    [
        m.amplitude,
        m.max,
        m.min,
        m.mean,
        m.h1,
        m.phase_deg,
        m.h2,
        m.thd,
    ]
}

/// Header of the sweep CSV.
fn sweep_header(runs: &[SweepRun]) -> Vec<String> {
    let first = &runs[0].sweep;
    let mut h = vec![first.param.clone(), "direction".to_string()];
    if let Some((name, _)) = runs[0].tag() {
        h.push(name.to_string());
    }
    for r in &first.responses {
        for m in MEASURES {
            h.push(format!("{r}_{m}"));
        }
    }
    h.extend(["settled", "periods", "period_multiple", "refined"].map(String::from));
    h
}

/// Sweep CSV: one row per frequency, direction and `--values` entry. An incomplete
/// (interrupted) sweep ends with a comment line `# incomplete: ...`.
pub fn write_sweep_csv(path: &str, runs: &[SweepRun]) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{}", sweep_header(runs).join(","))?;
        for run in runs {
            for p in &run.sweep.points {
                write!(w, "{},{}", num(p.steady.omega), p.direction.name())?;
                if let Some((_, v)) = run.tag() {
                    write!(w, ",{}", num(v))?;
                }
                for m in &p.steady.measures {
                    for x in measure_values(m) {
                        write!(w, ",{}", num(x))?;
                    }
                }
                writeln!(
                    w,
                    ",{},{},{},{}",
                    u8::from(p.steady.settled),
                    p.steady.periods,
                    p.steady.period_multiple,
                    u8::from(p.refined)
                )?;
            }
        }
        if runs.iter().any(|r| !r.sweep.complete) {
            writeln!(
                w,
                "# incomplete: interrupted; the rows above are the frequencies completed"
            )?;
        }
        Ok(())
    })
}

/// Sweep JSON: equilibrium, points (the CSV rows as objects), peaks, hysteresis.
pub fn sweep_json(runs: &[SweepRun], provenance: &Provenance) -> Value {
    let header = sweep_header(runs);
    let mut points = Vec::new();
    let mut peaks = Vec::new();
    let mut hysteresis = Vec::new();
    for run in runs {
        let s = &run.sweep;
        for p in &s.points {
            let mut o = Map::new();
            let mut k = 0;
            let mut put = |o: &mut Map<String, Value>, v: Value| {
                o.insert(header[k].clone(), v);
                k += 1;
            };
            put(&mut o, json!(p.steady.omega));
            put(&mut o, json!(p.direction.name()));
            if let Some((_, v)) = run.tag() {
                put(&mut o, json!(v));
            }
            for m in &p.steady.measures {
                for x in measure_values(m) {
                    put(&mut o, json!(x));
                }
            }
            put(&mut o, json!(p.steady.settled));
            put(&mut o, json!(p.steady.periods));
            put(&mut o, json!(p.steady.period_multiple));
            put(&mut o, json!(p.refined));
            points.push(Value::Object(o));
        }
        for pk in &s.peaks {
            let mut v = json!(pk);
            if let Some((name, val)) = run.tag() {
                v[name] = json!(val);
            }
            peaks.push(v);
        }
        for h in &s.hysteresis {
            let mut v = json!(h);
            if let Some((name, val)) = run.tag() {
                v[name] = json!(val);
            }
            hysteresis.push(v);
        }
    }
    let first = &runs[0].sweep;
    let mut out = json!({
        "equilibrium": coordinates_json(&first.coordinates, &first.equilibrium),
        "points": points,
        "peaks": peaks,
        "hysteresis": hysteresis,
        "complete": runs.iter().all(|r| r.sweep.complete),
        "provenance": provenance,
    });
    // With --values each run has its own equilibrium (a static load moves it).
    if runs.iter().any(|r| r.value.is_some()) {
        out["equilibria"] = runs
            .iter()
            .map(|r| {
                let mut e = json!({
                    "coordinates": coordinates_json(&r.sweep.coordinates, &r.sweep.equilibrium)
                });
                if let Some((name, v)) = r.tag() {
                    e[name] = json!(v);
                }
                e
            })
            .collect();
    }
    out
}
