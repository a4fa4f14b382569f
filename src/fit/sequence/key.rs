//! Resume keys: what a frame's stored results were computed from.
//!
//! A key is a map from entry names to strings: content hashes of the inputs (FNV-1a, 64 bit,
//! as 16 hex digits; stable across platforms and versions) and readable descriptions of the
//! options. Two keys are equal when every entry is; [`ResumeKey::changed`] names the
//! entries that differ.

use crate::fit::landmarks::Landmark;
use crate::spline::Spline;
use image::DynamicImage;
use std::collections::BTreeMap;

/// FNV-1a, 64 bit.
pub(super) struct Fnv(u64);

impl Fnv {
    pub(super) fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    pub(super) fn bytes(&mut self, b: &[u8]) -> &mut Fnv {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
        self
    }

    /// A length-prefixed string (so concatenations cannot collide).
    pub(super) fn text(&mut self, s: &str) -> &mut Fnv {
        self.bytes(&(s.len() as u64).to_le_bytes()).bytes(s.as_bytes())
    }

    pub(super) fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// Hash of an image's type, size and samples.
pub(crate) fn image_hash(img: &DynamicImage) -> String {
    let mut h = Fnv::new();
    h.text(&format!("{:?} {}x{}", img.color(), img.width(), img.height())).bytes(img.as_bytes());
    h.hex()
}

/// Hash of a deformation: degree, mesh (snapped vertices, triangles), exact control points
/// and 2.5D layers.
pub(super) fn spline_hash(s: &Spline) -> String {
    let mut h = Fnv::new();
    h.text(&format!("degree {} grid {}", s.degree(), s.mesh().grid_denominator()));
    for v in s.mesh().vertices() {
        h.bytes(&v[0].to_le_bytes()).bytes(&v[1].to_le_bytes());
    }
    for t in s.mesh().triangles() {
        for &i in t {
            h.bytes(&(i as u64).to_le_bytes());
        }
    }
    for p in s.points() {
        for c in p {
            h.text(&c.to_string());
        }
    }
    h.text(&format!("{:?}", s.z_layers()));
    h.hex()
}

/// Hash of landmark lists (names, points bit for bit, weights).
pub(super) fn landmarks_hash<'a>(sets: impl IntoIterator<Item = &'a [Landmark]>) -> String {
    let mut h = Fnv::new();
    for set in sets {
        h.bytes(&(set.len() as u64).to_le_bytes());
        for l in set {
            h.text(l.name.as_deref().unwrap_or("\u{0}"));
            for v in [l.src[0], l.src[1], l.dst[0], l.dst[1], l.weight] {
                h.bytes(&v.to_bits().to_le_bytes());
            }
        }
    }
    h.hex()
}

/// What a frame's results were computed from (see the module docs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ResumeKey(pub BTreeMap<String, String>);

impl ResumeKey {
    /// Sets one entry.
    pub fn set(&mut self, name: &str, value: impl Into<String>) -> &mut ResumeKey {
        self.0.insert(name.to_string(), value.into());
        self
    }

    /// The entries whose values differ between `self` and `other` (present in one only
    /// counts as different), in name order.
    pub fn changed(&self, other: &ResumeKey) -> Vec<String> {
        let mut names: Vec<&String> = self.0.keys().chain(other.0.keys()).collect();
        names.sort();
        names.dedup();
        names.into_iter().filter(|n| self.0.get(*n) != other.0.get(*n)).cloned().collect()
    }

    /// As a JSON object of strings.
    pub(crate) fn to_json(&self) -> serde_json::Value {
        serde_json::Value::Object(
            self.0.iter().map(|(k, v)| (k.clone(), serde_json::Value::from(v.as_str()))).collect(),
        )
    }

    /// From a JSON object of strings (`None` for anything else).
    pub(crate) fn from_json(v: &serde_json::Value) -> Option<ResumeKey> {
        let m = v.as_object()?;
        let mut out = BTreeMap::new();
        for (k, v) in m {
            out.insert(k.clone(), v.as_str()?.to_string());
        }
        Some(ResumeKey(out))
    }
}
