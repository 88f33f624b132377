//! The number type every generic model function is written over.
//!
//! `f64` for plain evaluation, `Dual64` for one directional derivative (a column of the
//! constraint Jacobian A), `Dual2_64` for a second derivative along the motion (the bias b).

use num_dual::DualNum;

/// A real number or a dual number over `f64` (num-dual 0.15: `Primitive = f64`).
pub trait Scalar: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}
