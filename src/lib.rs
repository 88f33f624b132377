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
//!
//! Quick start: the shipped inceptor's undamped natural frequencies, with its datum solved
//! (`[trim]`) as the command line does. Analyses take the compiled [`System`].
//!
//! ```
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/inceptor.toml");
//! let model = detune::Model::load(path).unwrap();
//! let sys = detune::System::new(&model).unwrap();
//! let (sys, solved) = detune::statics::trim::trim(&sys).unwrap();
//! assert_eq!(solved[0].0, "L0"); // the force sensor's natural length, m
//! let modes = detune::linear::modal_analysis(&sys, None).unwrap();
//! let omega: Vec<f64> = modes.undamped_omega2.iter().map(|w2| w2.sqrt()).collect();
//! assert!((omega[0] - 12.9748400163).abs() < 1e-8); // rad/s
//! assert!((omega[1] - 26.7664432852).abs() < 1e-8);
//! ```

pub mod check;
pub mod diag;
pub mod draw;
pub mod dynamics;
pub mod environment;
pub mod failure;
pub mod frequency;
#[doc(hidden)]
pub mod fuzz_harness;
pub mod kinematics;
pub mod linalg;
pub mod linear;
pub mod margins;
pub mod model;
pub mod output;
pub mod periodic;
pub mod report;
pub mod request;
pub mod scalar;
pub mod statics;
pub mod system;
pub mod tune;

pub use diag::{Error, Result};
pub use dynamics::simulate::{SimOptions, Trajectory, simulate};
pub use dynamics::{State, assemble};
pub use model::Model;
pub use system::System;
