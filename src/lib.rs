//! detune: preliminary-design dynamics of constrained mechanisms.
//!
//! Pipeline (data flows one way):
//!
//! ```text
//! model file (TOML) ──Model::load──▶ Model ──System::new──▶ System (Φ, A, b, M, f)
//!                                                      │
//!                      dynamics::assemble ─▶ State ─▶ dynamics::simulate::simulate
//!                                                      │
//!                                                  output (CSV, JSON, SVG)
//! ```
//!
//! The equations of motion are the Udwadia–Kalaba fundamental equation
//! `v̇ = a + M^-½ (A M^-½)⁺ (b − A a)`, with A and b from automatic differentiation of the
//! model's constraint function (see `docs/theory.md`).

pub mod check;
pub mod diag;
pub mod draw;
pub mod dynamics;
pub mod failure;
pub mod frequency;
pub mod kinematics;
pub mod linalg;
pub mod linear;
pub mod model;
pub mod output;
pub mod request;
pub mod scalar;
pub mod statics;
pub mod system;

pub use diag::{Error, Result};
pub use dynamics::simulate::{SimOptions, Trajectory, simulate};
pub use dynamics::{State, assemble};
pub use model::Model;
pub use system::System;
