//! The input of `trimorph solve` ([`Problem`]): JSON read in one streaming pass.
//!
//! The text is decoded once, front to back, straight into the problem's rows: every number
//! goes from its decimal text to an exact [`Rat`] (or an [`Int`] for the coefficients of
//! `R`) as the parser reaches it, and no JSON tree (`serde_json::Value`) is ever built. A
//! problem of `k` numbers therefore costs one small text per number while it is read, and
//! its memory is that of the exact values themselves. [`Problem::from_reader`] reads from
//! any [`std::io::Read`] the same way, without holding the text.
//!
//! The keys are those of [`super::problem`]'s table, in any order. What can be checked at
//! once is checked where it is read (types, decimal syntax, integer coefficients, positive
//! and bounded weights, a key given twice in one object); what needs other keys (the number
//! of parameters `n` from `"P"`, the dimension `d`, the number of constraints `m`, the derived
//! set) is checked after the last key, in the order `P`, `R`, `Q`, `anchors`, `derived`,
//! `hints`, `weights`. Every error names its element (`P[3][1]`, `R.rows[7][2][0]`,
//! `anchors."12"`), built only when the error happens. From text, a document that is not
//! valid JSON is always reported as such ([`ProblemError::Json`]), even when a wrong value
//! comes before the syntax error.

use super::EclesError;
use crate::exact::matrix::{parse_rat, Rat};
use crate::exact::Int;
use crate::json::{Keys, DUPLICATE, NUMBER_TOKEN};
use num_traits::Zero;
use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use std::cell::RefCell;
use std::collections::HashSet;
use std::fmt;

/// Errors reading a problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProblemError {
    /// Not valid JSON.
    #[error("not valid JSON: {0}")]
    Json(String),
    /// A key is missing or holds a value of the wrong kind.
    #[error("{path}: {message}")]
    Key {
        /// Where, e.g. `P[3][1]` or `anchors."7"`.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The edit itself is malformed (indices, sizes, weights).
    #[error("{0}")]
    Edit(#[from] EclesError),
}

/// A [`ProblemError::Key`] at `path`.
pub(super) fn key_err(path: impl Into<String>, message: impl Into<String>) -> ProblemError {
    ProblemError::Key { path: path.into(), message: message.into() }
}

/// Where a value sits in the document, as a chain of segments on the stack; formatted
/// (`R.rows[3][1][0]`, `anchors."7"`) only for an error message.
#[derive(Clone, Copy)]
struct Path<'a> {
    seg: Seg<'a>,
    parent: Option<&'a Path<'a>>,
}

#[derive(Clone, Copy)]
enum Seg<'a> {
    Root(&'a str),
    Index(usize),
    Key(&'a str),
}

impl<'a> Path<'a> {
    fn root(name: &'a str) -> Path<'a> {
        Path { seg: Seg::Root(name), parent: None }
    }
    fn index(&'a self, i: usize) -> Path<'a> {
        Path { seg: Seg::Index(i), parent: Some(self) }
    }
    fn key(&'a self, k: &'a str) -> Path<'a> {
        Path { seg: Seg::Key(k), parent: Some(self) }
    }
}

impl fmt::Display for Path<'_> {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        if let Some(p) = self.parent {
            p.fmt(f)?;
        }
        match self.seg {
            Seg::Root(s) => f.write_str(s),
            Seg::Index(i) => write!(f, "[{i}]"),
            Seg::Key(k) => write!(f, ".\"{k}\""),
        }
    }
}

/// The first problem error met while parsing. The parser is stopped with a marker error;
/// the reader then reports this error instead of the parser's.
#[derive(Default)]
struct Ctx {
    error: RefCell<Option<ProblemError>>,
}

impl Ctx {
    fn fail<E: de::Error>(&self, e: ProblemError) -> E {
        self.error.borrow_mut().get_or_insert(e);
        E::custom("(trimorph problem error)")
    }
}

/// The JSON text of a value that is not what was expected, cut at 40 characters.
fn shorten(s: String) -> String {
    match s.char_indices().nth(40) {
        Some((i, _)) => format!("{}...", &s[..i]),
        None => s,
    }
}

/// One kind of value the problem expects at some place. Each method handles one kind of
/// JSON value; the defaults refuse it with "`expected`, found ...".
trait Shape<'de>: Sized {
    type Out;
    /// Where the value is.
    fn path(&self) -> String;
    /// What was expected, e.g. "expected an array of rows".
    fn expected(&self) -> String;
    fn wrong(&self, found: String) -> ProblemError {
        key_err(self.path(), format!("{}, found {}", self.expected(), shorten(found)))
    }
    fn number(self, text: &str) -> Result<Self::Out, ProblemError> {
        Err(self.wrong(text.to_string()))
    }
    fn string(self, s: &str) -> Result<Self::Out, ProblemError> {
        Err(self.wrong(serde_json::to_string(s).unwrap_or_default()))
    }
    fn boolean(self, b: bool) -> Result<Self::Out, ProblemError> {
        Err(self.wrong(b.to_string()))
    }
    fn null(self) -> Result<Self::Out, ProblemError> {
        Err(self.wrong("null".into()))
    }
    fn seq<A: SeqAccess<'de>>(self, ctx: &Ctx, _: A) -> Result<Self::Out, A::Error> {
        Err(ctx.fail(self.wrong("an array".into())))
    }
    /// An object whose first key (already read) is `first`.
    fn map<A: MapAccess<'de>>(
        self,
        ctx: &Ctx,
        _first: Option<String>,
        _: A,
    ) -> Result<Self::Out, A::Error> {
        Err(ctx.fail(self.wrong("an object".into())))
    }
}

/// A value of shape `S`, read by `deserialize_any`. With `serde_json`'s arbitrary precision,
/// a number arrives as a one-key map holding its text; it goes to [`Shape::number`].
struct Node<'c, S> {
    ctx: &'c Ctx,
    shape: S,
}

fn node<S>(ctx: &Ctx, shape: S) -> Node<'_, S> {
    Node { ctx, shape }
}

impl<'de, S: Shape<'de>> DeserializeSeed<'de> for Node<'_, S> {
    type Value = S::Out;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<S::Out, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, S: Shape<'de>> Visitor<'de> for Node<'_, S> {
    type Value = S::Out;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(&self.shape.expected())
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<S::Out, E> {
        self.shape.boolean(v).map_err(|e| self.ctx.fail(e))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<S::Out, E> {
        self.shape.number(&v.to_string()).map_err(|e| self.ctx.fail(e))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<S::Out, E> {
        self.shape.number(&v.to_string()).map_err(|e| self.ctx.fail(e))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<S::Out, E> {
        self.shape.number(&v.to_string()).map_err(|e| self.ctx.fail(e))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<S::Out, E> {
        self.shape.string(v).map_err(|e| self.ctx.fail(e))
    }
    fn visit_unit<E: de::Error>(self) -> Result<S::Out, E> {
        self.shape.null().map_err(|e| self.ctx.fail(e))
    }
    fn visit_none<E: de::Error>(self) -> Result<S::Out, E> {
        self.shape.null().map_err(|e| self.ctx.fail(e))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, a: A) -> Result<S::Out, A::Error> {
        self.shape.seq(self.ctx, a)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<S::Out, A::Error> {
        let first = a.next_key::<String>()?;
        if first.as_deref() == Some(NUMBER_TOKEN) {
            let text: String = a.next_value()?;
            return self.shape.number(&text).map_err(|e| self.ctx.fail(e));
        }
        self.shape.map(self.ctx, first, a)
    }
}

/// An exact number: a JSON number (its decimal text) or a string `"p/q"`, `"p"`, decimal.
struct Number<'p>(Path<'p>);

impl<'de> Shape<'de> for Number<'_> {
    type Out = Rat;
    fn path(&self) -> String {
        self.0.to_string()
    }
    fn expected(&self) -> String {
        "expected a number or a \"p/q\" string".into()
    }
    fn number(self, text: &str) -> Result<Rat, ProblemError> {
        parse_rat(text).map_err(|e| key_err(self.path(), e.to_string()))
    }
    fn string(self, s: &str) -> Result<Rat, ProblemError> {
        self.number(s)
    }
}

/// An integer coefficient of `R` (a number or a string, with an integer value).
struct Coef<'p>(Path<'p>);

impl<'de> Shape<'de> for Coef<'_> {
    type Out = Int;
    fn path(&self) -> String {
        self.0.to_string()
    }
    fn expected(&self) -> String {
        "expected a number or a \"p/q\" string".into()
    }
    fn number(self, text: &str) -> Result<Int, ProblemError> {
        if let Ok(v) = text.parse::<i64>() {
            return Ok(Int::from(v));
        }
        let v = Number(self.0).number(text)?;
        if !v.is_integer() {
            return Err(key_err(self.path(), "coefficients must be integers"));
        }
        Ok(v.to_integer())
    }
    fn string(self, s: &str) -> Result<Int, ProblemError> {
        self.number(s)
    }
}

/// A nonnegative index (a column of `R`, a derived parameter).
struct Index<'p> {
    path: Path<'p>,
    what: &'static str,
}

impl<'de> Shape<'de> for Index<'_> {
    type Out = usize;
    fn path(&self) -> String {
        self.path.to_string()
    }
    fn expected(&self) -> String {
        format!("expected {}", self.what)
    }
    fn number(self, text: &str) -> Result<usize, ProblemError> {
        match text.parse::<u64>() {
            Ok(v) => Ok(usize::try_from(v).unwrap_or(usize::MAX)),
            Err(_) => Err(self.wrong(text.to_string())),
        }
    }
}

/// An array whose elements have the shapes `elem(path of element k)`; `what` names the
/// elements for the "expected an array of ..." message.
struct Array<'p, F> {
    path: Path<'p>,
    what: &'static str,
    elem: F,
}

/// The elements of an array, each read with a fresh seed for its index.
trait Elements<'de> {
    type Item;
    fn next<A: SeqAccess<'de>>(
        &mut self,
        ctx: &Ctx,
        path: &Path,
        k: usize,
        a: &mut A,
    ) -> Result<Option<Self::Item>, A::Error>;
}

impl<'de, F: Elements<'de>> Shape<'de> for Array<'_, F> {
    type Out = Vec<F::Item>;
    fn path(&self) -> String {
        self.path.to_string()
    }
    fn expected(&self) -> String {
        match self.what {
            "" => "expected an array".into(),
            w => format!("expected an array of {w}"),
        }
    }
    fn seq<A: SeqAccess<'de>>(mut self, ctx: &Ctx, mut a: A) -> Result<Self::Out, A::Error> {
        let mut out = Vec::with_capacity(a.size_hint().unwrap_or(0));
        while let Some(x) = self.elem.next(ctx, &self.path, out.len(), &mut a)? {
            out.push(x);
        }
        Ok(out)
    }
}

/// An [`Elements`] type `$name` whose element at `path` has the shape `$shape`.
macro_rules! elements {
    ($(#[$doc:meta])* $name:ident, $item:ty, |$path:ident| $shape:expr) => {
        $(#[$doc])*
        struct $name;
        impl<'de> Elements<'de> for $name {
            type Item = $item;
            fn next<A: SeqAccess<'de>>(
                &mut self,
                ctx: &Ctx,
                path: &Path,
                k: usize,
                a: &mut A,
            ) -> Result<Option<$item>, A::Error> {
                let $path = path.index(k);
                a.next_element_seed(node(ctx, $shape))
            }
        }
    };
}

elements!(
    /// Elements that are exact numbers.
    Numbers,
    Rat,
    |p| Number(p)
);

elements!(
    /// Elements that are rows of exact numbers.
    Rows,
    Vec<Rat>,
    |p| row(p)
);

fn row(path: Path) -> Array<Numbers> {
    Array { path, what: "", elem: Numbers }
}

fn rows(path: Path) -> Array<Rows> {
    Array { path, what: "rows", elem: Rows }
}

elements!(
    /// Elements that are parameter indices.
    Indices,
    usize,
    |p| Index { path: p, what: "a parameter index" }
);

/// A dense row of `R`: its length and its nonzero coefficients `(column, value)`.
pub(super) type DenseRow = (usize, Vec<(usize, Int)>);

/// Elements of a dense row of `R`: integer coefficients (zeros are counted, not kept).
struct DenseCoefs;
impl<'de> Shape<'de> for Array<'_, DenseCoefs> {
    type Out = DenseRow;
    fn path(&self) -> String {
        self.path.to_string()
    }
    fn expected(&self) -> String {
        "expected an array".into()
    }
    fn seq<A: SeqAccess<'de>>(self, ctx: &Ctx, mut a: A) -> Result<DenseRow, A::Error> {
        let (mut len, mut nz) = (0, Vec::new());
        while let Some(v) = a.next_element_seed(node(ctx, Coef(self.path.index(len))))? {
            if !v.is_zero() {
                nz.push((len, v));
            }
            len += 1;
        }
        Ok((len, nz))
    }
}

elements!(
    /// Rows of `R` in the dense form.
    DenseRows,
    DenseRow,
    |p| Array { path: p, what: "", elem: DenseCoefs }
);

/// One `[column, value]` pair of the sparse form.
struct Pair<'p>(Path<'p>);
impl<'de> Shape<'de> for Pair<'_> {
    type Out = (usize, Int);
    fn path(&self) -> String {
        self.0.to_string()
    }
    fn expected(&self) -> String {
        "expected [column, value]".into()
    }
    fn seq<A: SeqAccess<'de>>(self, ctx: &Ctx, mut a: A) -> Result<(usize, Int), A::Error> {
        let col = Index { path: self.0.index(0), what: "a column index" };
        let Some(c) = a.next_element_seed(node(ctx, col))? else {
            return Err(ctx.fail(self.wrong("an empty array".into())));
        };
        let Some(v) = a.next_element_seed(node(ctx, Coef(self.0.index(1))))? else {
            return Err(ctx.fail(self.wrong("one value".into())));
        };
        if a.next_element::<Keys>()?.is_some() {
            return Err(ctx.fail(self.wrong("more than two values".into())));
        }
        Ok((c, v))
    }
}

elements!(
    /// The `[column, value]` pairs of a sparse row.
    Pairs,
    (usize, Int),
    |p| Pair(p)
);

elements!(
    /// Rows of `R` in the sparse form.
    SparseRows,
    Vec<(usize, Int)>,
    |p| Array { path: p, what: "[column, value] pairs", elem: Pairs }
);

/// `"R"` as read: dense rows (length, nonzeros) or sparse rows (pairs in the file's order).
pub(super) enum RawR {
    /// Rows as (length, nonzeros).
    Dense(Vec<DenseRow>),
    /// Rows as pairs in the file's order.
    Sparse(Vec<Vec<(usize, Int)>>),
}

struct RShape;
impl<'de> Shape<'de> for RShape {
    type Out = RawR;
    fn path(&self) -> String {
        "R".into()
    }
    fn expected(&self) -> String {
        "expected an array of rows or {\"rows\": ...}".into()
    }
    fn seq<A: SeqAccess<'de>>(self, ctx: &Ctx, a: A) -> Result<RawR, A::Error> {
        let dense = Array { path: Path::root("R"), what: "rows", elem: DenseRows };
        dense.seq(ctx, a).map(RawR::Dense)
    }
    fn map<A: MapAccess<'de>>(
        self,
        ctx: &Ctx,
        first: Option<String>,
        mut a: A,
    ) -> Result<RawR, A::Error> {
        let mut out = None;
        let mut seen = HashSet::new();
        let mut key = first;
        while let Some(k) = key {
            if !seen.insert(k.clone()) {
                return Err(de::Error::custom(format_args!("{DUPLICATE}{k:?}")));
            }
            if k == "rows" {
                let sparse = Array { path: Path::root("R.rows"), what: "", elem: SparseRows };
                out = Some(a.next_value_seed(node(ctx, sparse))?);
            } else {
                a.next_value::<Keys>()?;
            }
            key = a.next_key()?;
        }
        match out {
            Some(r) => Ok(RawR::Sparse(r)),
            None => Err(ctx.fail(key_err(
                "R",
                "the sparse form needs \"rows\": [[[column, value], ...], ...]",
            ))),
        }
    }
}

/// How the values of an index object are read.
trait EntryValue<'de> {
    type Item;
    fn read<A: MapAccess<'de>>(ctx: &Ctx, path: Path, a: &mut A) -> Result<Self::Item, A::Error>;
}

/// Values that are rows (anchors, hints).
struct RowValues;
impl<'de> EntryValue<'de> for RowValues {
    type Item = Vec<Rat>;
    fn read<A: MapAccess<'de>>(ctx: &Ctx, path: Path, a: &mut A) -> Result<Vec<Rat>, A::Error> {
        a.next_value_seed(node(ctx, row(path)))
    }
}

/// Values that are numbers (weights).
struct NumberValues;
impl<'de> EntryValue<'de> for NumberValues {
    type Item = Rat;
    fn read<A: MapAccess<'de>>(ctx: &Ctx, path: Path, a: &mut A) -> Result<Rat, A::Error> {
        a.next_value_seed(node(ctx, Number(path)))
    }
}

/// An object `{"index": value}` (anchors, hints, weights), or `null` (absent): its entries
/// in the file's order, each key at most once.
struct IndexObject<V> {
    name: &'static str,
    values: std::marker::PhantomData<V>,
}

fn index_object<V>(name: &'static str) -> IndexObject<V> {
    IndexObject { name, values: std::marker::PhantomData }
}

impl<'de, V: EntryValue<'de>> Shape<'de> for IndexObject<V> {
    type Out = Option<Vec<(String, V::Item)>>;
    fn path(&self) -> String {
        self.name.into()
    }
    fn expected(&self) -> String {
        "expected an object {\"index\": ...}".into()
    }
    fn null(self) -> Result<Self::Out, ProblemError> {
        Ok(None)
    }
    fn map<A: MapAccess<'de>>(
        self,
        ctx: &Ctx,
        first: Option<String>,
        mut a: A,
    ) -> Result<Self::Out, A::Error> {
        let mut out = Vec::new();
        let mut seen = HashSet::new();
        let root = Path::root(self.name);
        let mut key = first;
        while let Some(k) = key {
            if !seen.insert(k.clone()) {
                return Err(de::Error::custom(format_args!("{DUPLICATE}{k:?}")));
            }
            let v = V::read(ctx, root.key(&k), &mut a)?;
            out.push((k, v));
            key = a.next_key()?;
        }
        Ok(Some(out))
    }
}

/// `true`, `false` or `null` (absent).
struct Flag(&'static str);
impl<'de> Shape<'de> for Flag {
    type Out = Option<bool>;
    fn path(&self) -> String {
        self.0.into()
    }
    fn expected(&self) -> String {
        "expected true or false".into()
    }
    fn boolean(self, b: bool) -> Result<Option<bool>, ProblemError> {
        Ok(Some(b))
    }
    fn null(self) -> Result<Option<bool>, ProblemError> {
        Ok(None)
    }
}

/// A string or `null` (absent); `expected` lists the accepted strings.
struct Word {
    name: &'static str,
    expected: &'static str,
}
impl<'de> Shape<'de> for Word {
    type Out = Option<String>;
    fn path(&self) -> String {
        self.name.into()
    }
    fn expected(&self) -> String {
        format!("expected {}", self.expected)
    }
    fn string(self, s: &str) -> Result<Option<String>, ProblemError> {
        Ok(Some(s.to_string()))
    }
    fn null(self) -> Result<Option<String>, ProblemError> {
        Ok(None)
    }
}

const METHODS: &str = "\"none\", \"gcd\" or \"turner\"";
pub(super) const PATHS: &str = "\"auto\", \"modular\" or \"fraction_free\"";

/// Every key as read, before the checks that need other keys.
#[derive(Default)]
pub(super) struct Raw {
    pub(super) p: Option<Vec<Vec<Rat>>>,
    pub(super) r: Option<RawR>,
    pub(super) q: Option<Option<Vec<Vec<Rat>>>>,
    pub(super) anchors: Option<Vec<(String, Vec<Rat>)>>,
    pub(super) derived: Option<Vec<usize>>,
    pub(super) hints: Option<Vec<(String, Vec<Rat>)>>,
    pub(super) weights: Option<Vec<(String, Rat)>>,
    pub(super) strong: Option<bool>,
    pub(super) method: Option<String>,
    pub(super) path: Option<String>,
}

/// The top-level object.
struct Top;
impl<'de> Shape<'de> for Top {
    type Out = Raw;
    fn path(&self) -> String {
        "(top level)".into()
    }
    fn expected(&self) -> String {
        "expected a JSON object".into()
    }
    fn map<A: MapAccess<'de>>(
        self,
        ctx: &Ctx,
        first: Option<String>,
        mut a: A,
    ) -> Result<Raw, A::Error> {
        let mut raw = Raw::default();
        let mut seen = HashSet::new();
        let mut key = first;
        while let Some(k) = key {
            if !seen.insert(k.clone()) {
                return Err(de::Error::custom(format_args!("{DUPLICATE}{k:?}")));
            }
            match k.as_str() {
                "P" => raw.p = Some(a.next_value_seed(node(ctx, rows(Path::root("P"))))?),
                "R" => raw.r = Some(a.next_value_seed(node(ctx, RShape))?),
                "Q" => raw.q = Some(a.next_value_seed(node(ctx, OptRows("Q")))?),
                "anchors" => {
                    let o = index_object::<RowValues>("anchors");
                    raw.anchors = a.next_value_seed(node(ctx, o))?;
                }
                "derived" => {
                    let d = Array { path: Path::root("derived"), what: "indices", elem: Indices };
                    raw.derived = Some(a.next_value_seed(node(ctx, d))?);
                }
                "hints" => {
                    raw.hints = a.next_value_seed(node(ctx, index_object::<RowValues>("hints")))?
                }
                "weights" => {
                    let o = index_object::<NumberValues>("weights");
                    raw.weights = a.next_value_seed(node(ctx, o))?;
                }
                "strong" => raw.strong = a.next_value_seed(node(ctx, Flag("strong")))?,
                "method" => {
                    let w = Word { name: "method", expected: METHODS };
                    raw.method = a.next_value_seed(node(ctx, w))?;
                }
                "path" => {
                    let w = Word { name: "path", expected: PATHS };
                    raw.path = a.next_value_seed(node(ctx, w))?;
                }
                _ => {
                    a.next_value::<Keys>()?;
                }
            }
            key = a.next_key()?;
        }
        Ok(raw)
    }
}

/// Rows or `null` (`"Q"`).
struct OptRows(&'static str);
impl<'de> Shape<'de> for OptRows {
    type Out = Option<Vec<Vec<Rat>>>;
    fn path(&self) -> String {
        self.0.into()
    }
    fn expected(&self) -> String {
        "expected an array of rows".into()
    }
    fn null(self) -> Result<Self::Out, ProblemError> {
        Ok(None)
    }
    fn seq<A: SeqAccess<'de>>(self, ctx: &Ctx, a: A) -> Result<Self::Out, A::Error> {
        rows(Path::root(self.0)).seq(ctx, a).map(Some)
    }
}

/// Reads a problem's raw parts from a `serde_json` deserializer (text or reader) in one
/// pass ([`Problem::from_json`](super::problem::Problem::from_json) checks and builds it).
pub(super) fn read<'de, R: serde_json::de::Read<'de>>(
    mut de: serde_json::Deserializer<R>,
) -> Result<Raw, ProblemError> {
    let ctx = Ctx::default();
    let raw = node(&ctx, Top).deserialize(&mut de).and_then(|raw| de.end().map(|()| raw));
    raw.map_err(|e| ctx.error.into_inner().unwrap_or_else(|| ProblemError::Json(e.to_string())))
}

#[cfg(test)]
#[path = "input_tests.rs"]
mod tests;
