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

impl Table {
    /// Renders the table in `format`.
    pub fn render(&self, format: Format) -> String {
        match format {
            Format::Table => {
                let widths: Vec<usize> = (0..self.columns.len())
                    .map(|j| {
                        self.rows
                            .iter()
                            .map(|r| cell(&r[j]).chars().count())
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
                out.extend(self.rows.iter().map(|r| line(r.iter().map(cell).collect())));
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
        assert_eq!(t.render(Format::Table), " wi  kind\n1.0   a,b\n");
        let back: Value = serde_json::from_str(&t.render(Format::Json)).unwrap();
        assert_eq!(back, json!([{"wi": 1.0, "kind": "a,b"}]));
    }
}
