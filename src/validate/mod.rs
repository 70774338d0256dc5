//! Validation studies shared by `xpflow validate`, `make validate` and the test suite: each
//! returns its measured numbers and a verdict against named thresholds.

pub mod couette_wall_mode;
pub mod extrudate;
pub mod film_polymer;
pub mod moving;
pub mod near_contact;
pub mod particles;
pub mod stokes;
pub mod variable_steps;
pub mod viscoelastic;
pub mod xstokes;

/// One row of a convergence table.
#[derive(Debug, Clone)]
pub struct ConvRow {
    /// Mesh label, e.g. "32x16".
    pub mesh: String,
    /// Characteristic element size.
    pub h: f64,
    /// Number of unknowns.
    pub dofs: usize,
    /// Named error values, in the order of [`ConvStudy::columns`].
    pub errors: Vec<f64>,
}

/// A convergence study: rows, the fitted rates per column and the required minimum rates.
#[derive(Debug, Clone)]
pub struct ConvStudy {
    /// Title.
    pub title: String,
    /// Column names of the errors.
    pub columns: Vec<String>,
    /// Rows, coarse to fine.
    pub rows: Vec<ConvRow>,
    /// Minimum acceptable fitted rate per column.
    pub min_rates: Vec<f64>,
}

impl ConvStudy {
    /// Fitted log–log slopes of each error column against h.
    pub fn rates(&self) -> Vec<f64> {
        let h: Vec<f64> = self.rows.iter().map(|r| r.h).collect();
        (0..self.columns.len())
            .map(|c| {
                let e: Vec<f64> = self.rows.iter().map(|r| r.errors[c]).collect();
                crate::solver::norms::fitted_rate(&h, &e)
            })
            .collect()
    }

    /// Whether every fitted rate reaches its minimum.
    pub fn passed(&self) -> bool {
        self.rates()
            .iter()
            .zip(&self.min_rates)
            .all(|(r, m)| r >= m)
    }

    /// Markdown table with rates and verdict.
    pub fn to_markdown(&self) -> String {
        let mut s = format!("### {}\n\n| mesh | h | unknowns |", self.title);
        for c in &self.columns {
            s += &format!(" {c} |");
        }
        s += "\n|---|---|---|";
        s += &"---|".repeat(self.columns.len());
        s += "\n";
        for r in &self.rows {
            s += &format!("| {} | {:.4e} | {} |", r.mesh, r.h, r.dofs);
            for e in &r.errors {
                s += &format!(" {e:.3e} |");
            }
            s += "\n";
        }
        s += "| **fitted rate** | | |";
        for r in self.rates() {
            s += &format!(" **{r:.3}** |");
        }
        s += "\n| required | | |";
        for m in &self.min_rates {
            s += &format!(" ≥ {m} |");
        }
        s += &format!(
            "\n\nverdict: {}\n",
            if self.passed() { "PASS" } else { "FAIL" }
        );
        s
    }
}
