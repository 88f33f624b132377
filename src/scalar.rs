//! The number type every generic model function is written over, and where the values of
//! parameters come from when it is evaluated.
//!
//! `f64` for plain evaluation, `Dual64` for one directional derivative (a column of the
//! constraint Jacobian A, or a derivative with respect to a parameter), `Dual2_64` for a
//! second derivative along the motion (the bias b), `HyperDual64` for mixed second
//! derivatives.

use num_dual::DualNum;

/// A real number or a dual number over `f64` (num-dual 0.15: `Primitive = f64`).
pub trait Scalar: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// The live values a compiled model reads while it is evaluated: its parameters (by
/// index) and the element coefficients derived from them (masses, stiffnesses, points).
///
/// [`Plain`] reads the current `f64` values; [`Seeded`] reads values of the evaluation's
/// own number type, so that a dual part seeded on a parameter carries ∂/∂p through every
/// coefficient and expression that depends on it (derivatives with respect to parameters
/// by automatic differentiation, like A and b).
pub trait Env<D>: Copy {
    fn param(self, i: usize) -> D;
    fn coef(self, i: usize) -> D;
    /// x · coefficient i (an `f64` product where the coefficient carries no derivative).
    fn mul_coef(self, i: usize, x: D) -> D;
}

/// Current values, as `f64`.
#[derive(Debug, Clone, Copy)]
pub struct Plain<'a> {
    pub params: &'a [f64],
    pub coefs: &'a [f64],
}

impl<D: Scalar> Env<D> for Plain<'_> {
    #[inline(always)]
    fn param(self, i: usize) -> D {
        D::from(self.params[i])
    }
    #[inline(always)]
    fn coef(self, i: usize) -> D {
        D::from(self.coefs[i])
    }
    #[inline(always)]
    fn mul_coef(self, i: usize, x: D) -> D {
        x * self.coefs[i]
    }
}

/// Values carrying derivatives (see `System::seeded`).
#[derive(Debug, Clone, Copy)]
pub struct Seeded<'a, D> {
    pub params: &'a [D],
    pub coefs: &'a [D],
}

impl<D: Scalar> Env<D> for Seeded<'_, D> {
    #[inline(always)]
    fn param(self, i: usize) -> D {
        self.params[i]
    }
    #[inline(always)]
    fn coef(self, i: usize) -> D {
        self.coefs[i]
    }
    #[inline(always)]
    fn mul_coef(self, i: usize, x: D) -> D {
        x * self.coefs[i]
    }
}

/// No parameters: for expressions compiled without any (tests, folded constants).
pub const NO_ENV: Plain<'static> = Plain {
    params: &[],
    coefs: &[],
};
