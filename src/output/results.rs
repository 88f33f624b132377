//! CSV and JSON layouts of the analyses' results (pure functions of result structs).

use super::{Provenance, num, write_atomic};
use crate::diag::Result;
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

fn branch_point_json(names: &[String], p: &BranchPoint) -> Value {
    json!({"value": p.value, "coordinates": coordinates_json(names, &p.q), "stable": p.stable})
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
