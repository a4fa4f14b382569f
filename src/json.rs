//! Strict JSON reading: a key that appears twice in one object is an error.
//!
//! RFC 8259 (section 4) only says that names "SHOULD be unique" and leaves the meaning of a
//! repeated name to the reader; `serde_json` keeps the last value silently. In a trimorph
//! file a repeated key is almost always an editing mistake (a control point pasted twice, an
//! option given two values), so every file trimorph reads as JSON goes through [`parse`],
//! which refuses it naming the key, its line and column. Below every other module, so that
//! any of them may read JSON.

use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::Value;
use std::fmt;

/// Parses JSON text into a [`Value`], refusing duplicate keys ("duplicate key "x" at line
/// L column C"). Otherwise the same as `serde_json::from_str::<Value>` (numbers keep their
/// text: the crate reads JSON with `serde_json`'s arbitrary precision).
///
/// ```
/// let v = trimorph::json::parse(r#"{"a": [1, {"b": 2}]}"#).unwrap();
/// assert_eq!(v["a"][1]["b"], 2);
/// let e = trimorph::json::parse("{\"a\": 1,\n \"a\": 2}").unwrap_err();
/// assert!(e.to_string().starts_with("duplicate key \"a\" at line 2"), "{e}");
/// ```
pub fn parse(text: &str) -> Result<Value, serde_json::Error> {
    // One pass: the value is built and every object's keys checked as it is read (a file
    // of control points is a few hundred kilobytes, read at every command's start).
    serde_json::from_str::<Strict>(text).map(|s| s.0)
}

/// A [`Value`] read with every object's keys checked (the visitor of `serde_json`'s own
/// `Value`, plus the duplicate check).
struct Strict(Value);

/// The key under which `serde_json` (with `arbitrary_precision`) hands a number's text to
/// `deserialize_any`, as a one-entry map.
pub(crate) const NUMBER_TOKEN: &str = "$serde_json::private::Number";

impl<'de> Deserialize<'de> for Strict {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(StrictVisitor).map(Strict)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::Number(v.into()))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::Number(v.into()))
    }
    fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
        Ok(serde_json::Number::from_f64(v).map_or(Value::Null, Value::Number))
    }
    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_owned()))
    }
    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        Strict::deserialize(d).map(|s| s.0)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut v = Vec::with_capacity(seq.size_hint().unwrap_or(0));
        while let Some(Strict(x)) = seq.next_element()? {
            v.push(x);
        }
        Ok(Value::Array(v))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut m = serde_json::Map::new();
        let Some(first) = map.next_key::<String>()? else {
            return Ok(Value::Object(m));
        };
        if first == NUMBER_TOKEN {
            // A number, its text kept exactly (`Number`'s parser checks it once more).
            let text: String = map.next_value()?;
            return text.parse().map(Value::Number).map_err(de::Error::custom);
        }
        let Strict(v) = map.next_value()?;
        m.insert(first, v);
        while let Some(k) = map.next_key::<String>()? {
            if m.contains_key(&k) {
                return Err(de::Error::custom(format_args!("{DUPLICATE}{k:?}")));
            }
            let Strict(v) = map.next_value()?;
            m.insert(k, v);
        }
        Ok(Value::Object(m))
    }
}

/// Parses JSON text into `T` ([`serde::Deserialize`]), refusing duplicate keys first.
pub fn from_str<'a, T: Deserialize<'a>>(text: &'a str) -> Result<T, serde_json::Error> {
    check_keys(text)?;
    serde_json::from_str(text)
}

/// Whether `text` is valid JSON with no key given twice in one object (the checks of
/// [`parse`]), without building anything: one pass over the text.
pub(crate) fn check_syntax(text: &str) -> Result<(), serde_json::Error> {
    let mut de = serde_json::Deserializer::from_str(text);
    Keys::deserialize(&mut de)?;
    de.end()
}

/// One pass over the text that only looks at object keys: an error at the first key that
/// repeats in its object (syntax errors are left to the real parse, which reports them).
fn check_keys(text: &str) -> Result<(), serde_json::Error> {
    let mut de = serde_json::Deserializer::from_str(text);
    match Keys::deserialize(&mut de) {
        Err(e) if e.to_string().starts_with(DUPLICATE) => Err(e),
        _ => Ok(()),
    }
}

pub(crate) const DUPLICATE: &str = "duplicate key ";

/// Any JSON value, skipped, with the keys of every object checked (also how readers that
/// stream their input skip keys they do not use).
pub(crate) struct Keys;

impl<'de> Deserialize<'de> for Keys {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(KeysVisitor)
    }
}

struct KeysVisitor;

impl<'de> Visitor<'de> for KeysVisitor {
    type Value = Keys;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_str<E>(self, _: &str) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_unit<E>(self) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_none<E>(self) -> Result<Keys, E> {
        Ok(Keys)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Keys, D::Error> {
        Keys::deserialize(d)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Keys, A::Error> {
        while seq.next_element::<Keys>()?.is_some() {}
        Ok(Keys)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Keys, A::Error> {
        // (With arbitrary precision a number arrives as a one-key map: no duplicates.)
        let mut seen = std::collections::HashSet::new();
        while let Some(k) = map.next_key::<String>()? {
            if seen.contains(&k) {
                return Err(de::Error::custom(format_args!("{DUPLICATE}{k:?}")));
            }
            seen.insert(k);
            map.next_value::<Keys>()?;
        }
        Ok(Keys)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicate_keys_are_refused_at_any_depth_with_their_position() {
        let e = parse(r#"{"points": [[0, 0]], "x": {"k": 1, "k": 2}}"#).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("duplicate key \"k\" at line 1 column"), "{msg}");
        assert!(parse(r#"[{"a": 1}, {"a": 2}]"#).is_ok(), "the same key in two objects is fine");
    }

    /// Numbers keep their text exactly (arbitrary precision), as `serde_json`'s own `Value`
    /// keeps it; nesting, empty containers and escapes too; and the deep-nesting limit holds.
    #[test]
    fn exact_numbers_and_nesting_match_serde_json() {
        let text = r#"[0, -0, 1.5e-400, 123456789012345678901234567890, -1.25E+3, 0.1,
            {}, [], [[[]]], {"a": {"b": {"c": null}}}, "\u00e9\n", 18446744073709551615,
            -9223372036854775808, 3.0]"#;
        let want = serde_json::from_str::<Value>(text).unwrap();
        let got = parse(text).unwrap();
        assert_eq!(got, want);
        assert_eq!(got.to_string(), want.to_string());
        assert_eq!(got[2].to_string(), "1.5e-400");
        let deep = "[".repeat(200) + &"]".repeat(200);
        assert!(parse(&deep).is_err() && serde_json::from_str::<Value>(&deep).is_err());
        // A file that spells out serde_json's private number key is read as serde_json
        // reads it (as the number, or refused).
        for odd in [
            r#"{"$serde_json::private::Number": "1", "x": 2}"#,
            r#"{"$serde_json::private::Number": "12"}"#,
            r#"{"$serde_json::private::Number": "x"}"#,
            r#"{"x": 2, "$serde_json::private::Number": "1"}"#,
        ] {
            let (got, want) = (parse(odd), serde_json::from_str::<Value>(odd));
            assert_eq!(got.as_ref().ok(), want.as_ref().ok(), "{odd}");
            assert_eq!(got.is_err(), want.is_err(), "{odd}");
        }
    }

    #[test]
    fn values_are_those_of_serde_json() {
        let text = r#"{"a": [1, -2, 3.5, 1e300, "s", null, true, {"b": []}], "n": 1.000000000000000000001}"#;
        assert_eq!(parse(text).unwrap(), serde_json::from_str::<Value>(text).unwrap());
        for bad in ["", "{", "[1,]", "{} x"] {
            assert!(parse(bad).is_err(), "{bad:?}");
        }
    }
}
