//! A small result table rendered as aligned text, CSV or JSON.

use serde_json::{Map, Value};

/// Output format of query results.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned columns for the terminal.
    Table,
    /// Comma-separated values with a header line.
    Csv,
    /// A JSON array of objects.
    Json,
}

/// Rows of values under named columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column names.
    pub columns: Vec<String>,
    /// Rows, one value per column.
    pub rows: Vec<Vec<Value>>,
}

fn cell(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// A cell for a person to read: floats rounded to `digits` significant digits.
fn rounded_cell(v: &Value, digits: usize) -> String {
    match v {
        Value::Number(n) if n.is_f64() => n
            .as_f64()
            .map_or_else(|| n.to_string(), |x| round_sig(x, digits)),
        other => cell(other),
    }
}

/// Significant digits of a column's floats in [`Format::Table`] (CSV and JSON keep every digit):
/// times to 4 (t = 8.110), wall-clock and CPU seconds to 3, positions, velocities, ω* and gaps to 5; other
/// numbers (parameters) to 6, which writes 0.30000000000000004 as 0.3.
fn table_digits(column: &str) -> usize {
    match column {
        "wall_s" | "cpu_s" => 3,
        "t" | "t_decided" | "t_reached" | "t_end" | "t stored" => 4,
        "x" | "y" | "u" | "v" | "omega" | "theta" | "omega_star" | "r_star" | "r_star_final"
        | "gap_next_over_a" | "mean_gap" | "separation" | "swell" | "s_final" | "x_final"
        | "y_final" => 5,
        _ => 6,
    }
}

/// Magnitudes written with an exponent by [`round_sig`]: below 1e-4 and from 1e15 on.
const PLAIN_RANGE: std::ops::Range<f64> = 1e-4..1e15;

/// `x` rounded to `digits` significant digits, in the shortest form that shows them (trailing
/// zeros dropped: 8.109970490496691 → 8.11 at 4 digits, 1/6 → 0.1667, 2.0 → 2); an exponent
/// below 1e-4 and from 1e15 on (1.5e-5).
pub fn round_sig(x: f64, digits: usize) -> String {
    if !x.is_finite() || x == 0.0 {
        return if x == 0.0 { "0".into() } else { x.to_string() };
    }
    let digits = digits.clamp(1, 17);
    // scientific formatting rounds to the digits; parsing it back gives the shortest display
    let r: f64 = format!("{x:.*e}", digits - 1).parse().unwrap_or(x);
    if PLAIN_RANGE.contains(&r.abs()) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

impl Table {
    /// Renders the table in `format`.
    pub fn render(&self, format: Format) -> String {
        match format {
            Format::Table => {
                let digits: Vec<usize> = self.columns.iter().map(|c| table_digits(c)).collect();
                let cells: Vec<Vec<String>> = self
                    .rows
                    .iter()
                    .map(|r| {
                        r.iter()
                            .zip(&digits)
                            .map(|(v, d)| rounded_cell(v, *d))
                            .collect()
                    })
                    .collect();
                let widths: Vec<usize> = (0..self.columns.len())
                    .map(|j| {
                        cells
                            .iter()
                            .map(|r| r[j].chars().count())
                            .chain([self.columns[j].chars().count()])
                            .max()
                            .unwrap_or(0)
                    })
                    .collect();
                let line = |cells: Vec<String>| {
                    cells
                        .iter()
                        .zip(&widths)
                        .map(|(c, w)| format!("{c:>w$}"))
                        .collect::<Vec<_>>()
                        .join("  ")
                        .trim_end()
                        .to_string()
                };
                let mut out = vec![line(self.columns.clone())];
                out.extend(cells.into_iter().map(line));
                out.join("\n") + "\n"
            }
            Format::Csv => {
                let esc = |s: String| {
                    if s.contains([',', '"', '\n']) {
                        format!("\"{}\"", s.replace('"', "\"\""))
                    } else {
                        s
                    }
                };
                let mut out = self
                    .columns
                    .iter()
                    .map(|c| esc(c.clone()))
                    .collect::<Vec<_>>()
                    .join(",")
                    + "\n";
                for r in &self.rows {
                    out += &(r.iter().map(|v| esc(cell(v))).collect::<Vec<_>>().join(",") + "\n");
                }
                out
            }
            Format::Json => {
                let arr: Vec<Value> = self
                    .rows
                    .iter()
                    .map(|r| {
                        Value::Object(
                            self.columns
                                .iter()
                                .cloned()
                                .zip(r.iter().cloned())
                                .collect::<Map<_, _>>(),
                        )
                    })
                    .collect();
                serde_json::to_string_pretty(&Value::Array(arr)).unwrap_or_default() + "\n"
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    #[test]
    fn renders_all_formats() {
        let t = Table {
            columns: vec!["wi".into(), "kind".into()],
            rows: vec![vec![json!(1.0), json!("a,b")]],
        };
        assert_eq!(t.render(Format::Csv), "wi,kind\n1.0,\"a,b\"\n");
        assert_eq!(t.render(Format::Table), "wi  kind\n 1   a,b\n");
        let back: Value = serde_json::from_str(&t.render(Format::Json)).unwrap();
        assert_eq!(back, json!([{"wi": 1.0, "kind": "a,b"}]));
    }

    /// A table for a person rounds each column's floats (issue 28: `t_decided 8.109970490496691`,
    /// `wall_s 54.76213745`, positions `-0.503894345103742`); CSV and JSON keep every digit.
    #[test]
    fn tables_round_floats_per_column_and_csv_keeps_them() {
        let t = Table {
            columns: vec!["wi".into(), "t_decided".into(), "wall_s".into(), "x".into()],
            rows: vec![vec![
                json!(0.30000000000000004),
                json!(8.109970490496691),
                json!(54.76213745),
                json!(-0.503894345103742),
            ]],
        };
        let text = t.render(Format::Table);
        let row: Vec<&str> = text.lines().nth(1).unwrap().split_whitespace().collect();
        assert_eq!(row, ["0.3", "8.11", "54.8", "-0.50389"], "{text}");
        assert!(t
            .render(Format::Csv)
            .contains("8.109970490496691,54.76213745,-0.503894345103742"));
        assert_eq!(round_sig(1.0 / 6.0, 4), "0.1667");
        assert_eq!(round_sig(1.5e-5, 3), "1.5e-5");
        assert_eq!(round_sig(2.0, 4), "2");
    }
}
