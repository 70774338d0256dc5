//! Reading the text of a sweep or case file into a JSON value, with the same rules for both
//! formats: JSON refuses a key given twice (as TOML does; serde_json would keep the last one), and
//! TOML refuses `nan` and `inf` by name (JSON has no such numbers; converted, they would turn into
//! `null` and be reported as a wrong type).

use std::path::Path;

use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};

use super::error::ConfigError;

/// Parses `text` as JSON (`is_json`) or TOML into a value; `file` names the file in errors.
///
/// # Errors
/// [`ConfigError::Syntax`] for malformed text or a duplicate JSON key (with its path),
/// [`ConfigError::Sweep`] for a TOML `nan`/`inf`, naming its path.
pub fn parse(text: &str, is_json: bool, file: &Path) -> Result<Value, ConfigError> {
    let syntax = |format: &'static str, message: String| ConfigError::Syntax {
        file: file.to_path_buf(),
        format,
        message,
    };
    if is_json {
        let mut de = serde_json::Deserializer::from_str(text);
        let value = Strict { path: "" }
            .deserialize(&mut de)
            .and_then(|v| de.end().map(|_| v))
            .map_err(|e| syntax("JSON", e.to_string()))?;
        return Ok(value);
    }
    let table: toml::Table = toml::from_str(text).map_err(|e| syntax("TOML", e.to_string()))?;
    let table = toml::Value::Table(table);
    if let Some((path, x)) = non_finite(&table, "") {
        return Err(ConfigError::Sweep {
            file: file.to_path_buf(),
            field: path,
            message: format!("`{x}` is not a number xpflow can use: every number must be finite"),
        });
    }
    serde_json::to_value(table).map_err(|e| syntax("TOML", e.to_string()))
}

/// The first non-finite float in a TOML value, with its dotted path.
fn non_finite(v: &toml::Value, path: &str) -> Option<(String, f64)> {
    match v {
        toml::Value::Float(x) if !x.is_finite() => Some((path.to_string(), *x)),
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| non_finite(v, &join(path, k))),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| non_finite(v, &format!("{path}[{i}]"))),
        _ => None,
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// A JSON value that refuses duplicate keys, naming their path.
struct Strict<'a> {
    path: &'a str,
}

impl<'de> DeserializeSeed<'de> for Strict<'_> {
    type Value = Value;

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Strict<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, b: bool) -> Result<Value, E> {
        Ok(Value::Bool(b))
    }

    fn visit_i64<E>(self, x: i64) -> Result<Value, E> {
        Ok(Value::from(x))
    }

    fn visit_u64<E>(self, x: u64) -> Result<Value, E> {
        Ok(Value::from(x))
    }

    fn visit_f64<E>(self, x: f64) -> Result<Value, E> {
        Ok(Value::from(x))
    }

    fn visit_str<E>(self, s: &str) -> Result<Value, E> {
        Ok(Value::String(s.to_string()))
    }

    fn visit_string<E>(self, s: String) -> Result<Value, E> {
        Ok(Value::String(s))
    }

    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut items = Vec::new();
        while let Some(v) = seq.next_element_seed(Strict {
            path: &format!("{}[{}]", self.path, items.len()),
        })? {
            items.push(v);
        }
        Ok(Value::Array(items))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut out = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            let path = join(self.path, &key);
            if out.contains_key(&key) {
                return Err(de::Error::custom(format!(
                    "duplicate key `{path}`: give each key once"
                )));
            }
            let v = map.next_value_seed(Strict { path: &path })?;
            out.insert(key, v);
        }
        Ok(Value::Object(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// JSON keys given twice are refused with their path (issue 28: the last one won).
    #[test]
    fn json_duplicate_keys_are_refused() {
        let e = parse(
            r#"{"base": {"fluid": {"wi": 1, "wi": 2}}}"#,
            true,
            Path::new("s.json"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("duplicate key `base.fluid.wi`"), "{e}");
        let v = parse(r#"{"a": [1, 2.5, {"b": null}]}"#, true, Path::new("s.json")).unwrap();
        assert_eq!(v, serde_json::json!({"a": [1, 2.5, {"b": null}]}));
    }

    /// TOML `nan` and `inf` are refused by name and path (issue 28: "invalid type: null").
    #[test]
    fn toml_nan_and_inf_are_refused_by_name() {
        for (text, field) in [
            ("[base]\nfluid.wi = nan", "base.fluid.wi"),
            (
                "[axes]\n\"numerics.dt\" = [0.1, inf]",
                "axes.numerics.dt[1]",
            ),
        ] {
            let e = parse(text, false, Path::new("s.toml")).unwrap_err();
            assert_eq!(e.field(), Some(field), "{e}");
            assert!(e.to_string().contains("finite"), "{e}");
        }
    }
}
