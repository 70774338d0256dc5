//! `numerics.method`: how the particles enter the discretization — the thesis' XFEM (§2.3.2)
//! or the fictitious domain method it is measured against (§2.3.4, Table 2.4).

use serde::{Deserialize, Serialize};

use super::case::{InterfaceRule, Numerics, DEFAULT_QUADTREE_LEVEL};
use super::error::SpecError;

/// How the particles enter the discretization of the fields (`numerics.method`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// XFEM (default): the fluid domain only; elements cut by a particle boundary are integrated
    /// over their fluid part by the cut rule (`quadtree_level`, `interface`), elements inside a
    /// particle are removed.
    #[default]
    Xfem,
    /// The fictitious domain method: the particle interior is fluid, every element is integrated
    /// whole (no cut-cell quadrature, no removed unknowns), and the rigid-body motion is imposed
    /// on the particle boundary by the same weak condition as with XFEM. Velocity, pressure and
    /// log-conformation are continuous into the particles. Under-predicts the stress integral
    /// on the particle (the thesis: drag K about 60 %); the force of the rigid-body condition is
    /// the one to read (K_L, `xpflow validate cylinder --method fdm`).
    Fdm,
}

impl Method {
    /// Whether this is the default (`xfem`).
    pub fn is_xfem(&self) -> bool {
        *self == Method::Xfem
    }

    /// The name used in case files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Xfem => "xfem",
            Method::Fdm => "fdm",
        }
    }
}

impl Method {
    /// Refuses settings that the method does not use, so that a case never runs believing
    /// otherwise: the fictitious domain method has no cut cells, so a `quadtree_level` or an
    /// `interface` other than the default (the fields have defaults, so only a changed value is
    /// seen) would be ignored.
    ///
    /// # Errors
    /// The field that does not apply and what to change.
    pub(super) fn check(&self, n: &Numerics) -> Result<(), SpecError> {
        if *self != Method::Fdm {
            return Ok(());
        }
        let unused = |field: &str| {
            SpecError::new(
                field,
                "the fictitious domain method (method = \"fdm\") integrates every element \
                 whole and has no cut-cell quadrature: remove this field or use method = \"xfem\"",
            )
        };
        if n.quadtree_level != DEFAULT_QUADTREE_LEVEL {
            return Err(unused("numerics.quadtree_level"));
        }
        if n.interface != InterfaceRule::default() {
            return Err(unused("numerics.interface"));
        }
        Ok(())
    }
}
