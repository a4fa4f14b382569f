//! `trimorph mesh`, `trimorph edit` and `trimorph check`.

use super::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use crate::ecles::EclesError;
use crate::edit::select::Neighborhood;
use crate::edit::{EditError, Editor, Mode};
use crate::exact::{parse_rat, rat_to_string, Rat};
use crate::io::deformation::{self, LastEdit};
use crate::io::{read_text, write_atomic};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::jacobian::{certify, CertifyOptions, DetJ, SAMPLE_LEVEL};
use crate::spline::{Spline, ZLayers};
use anyhow::{anyhow, bail, Context, Result};
use num_traits::Zero;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

/// Reads `x,y` rows from CSV text (extra columns are allowed, and a header line: a first
/// line with no number in its first two columns).
pub fn read_points_csv(text: &str, source: &str) -> Result<Vec<[f64; 2]>> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cols: Vec<&str> = line.split([',', ';', '\t', ' ']).filter(|c| !c.is_empty()).collect();
        let parse = |c: Option<&&str>| c.and_then(|c| c.trim().parse::<f64>().ok());
        match (parse(cols.first()), parse(cols.get(1))) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => out.push([x, y]),
            // A header has no number in either column (a typo in one is an error).
            (None, None) if out.is_empty() && i == 0 => continue,
            _ => bail!("{source}, line {}: expected two numbers `x,y`, found `{line}`", i + 1),
        }
    }
    if out.is_empty() {
        bail!("{source}: no points");
    }
    Ok(out)
}

fn pair(text: &str, what: &str, sep: char) -> Result<(f64, f64)> {
    let (a, b) = text
        .split_once(sep)
        .ok_or_else(|| anyhow!("{what}: expected two numbers as A{sep}B, found `{text}`"))?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|_| anyhow!("{what}: `{a}` is not a number"))?,
        b.trim().parse().map_err(|_| anyhow!("{what}: `{b}` is not a number"))?,
    );
    if !a.is_finite() || !b.is_finite() {
        bail!("{what}: values must be finite");
    }
    Ok((a, b))
}

/// A frame size `W,H` in whole pixels (1 to 1,000,000 each).
pub fn parse_size(text: &str) -> Result<[f64; 2]> {
    let (w, h) = pair(text, "--size", ',')?;
    if w < 1.0 || h < 1.0 || w > 1e6 || h > 1e6 || w.fract() != 0.0 || h.fract() != 0.0 {
        bail!("--size: width and height must be whole numbers of pixels from 1 to 1000000");
    }
    Ok([w, h])
}

/// Options of `trimorph mesh`.
pub struct MeshArgs<'a> {
    pub points: Option<&'a Path>,
    pub outline: Option<&'a Path>,
    pub grid: Option<&'a str>,
    pub size: Option<&'a str>,
    pub obj: Option<&'a Path>,
    pub landmarks: Option<&'a Path>,
    pub margin: Option<f64>,
    pub max_edge: Option<f64>,
    pub min_angle: f64,
    pub degree: usize,
    pub snap: Option<i64>,
    pub z_range: Option<&'a str>,
    pub output: &'a Path,
}

/// `trimorph mesh`: an identity deformation over a new reference mesh.
pub fn mesh(a: MeshArgs) -> Result<()> {
    if a.snap.is_some_and(|g| !(1..=1 << 20).contains(&g)) {
        bail!("--snap must be between 1 and 1048576 (grid steps per unit)");
    }
    let opts = MeshOptions { grid: a.snap.unwrap_or(16) };
    if a.landmarks.is_none() && (a.margin.is_some() || a.max_edge.is_some()) {
        bail!("--margin and --max-edge go with --landmarks");
    }
    let mesh = match (a.points, a.grid, a.obj, a.landmarks) {
        (None, None, None, Some(l)) => {
            let size = a.size.ok_or_else(|| anyhow!("--landmarks needs --size W,H (the frame)"))?;
            let size = parse_size(size)?;
            let lms = crate::io::landmarks::read_landmarks(l)
                .with_context(|| format!("cannot read landmarks {}", l.display()))?;
            let sources: Vec<[f64; 2]> = lms.iter().map(|x| x.src).collect();
            let grid = a.snap.unwrap_or_else(|| crate::fit::frame::source_grid(&lms));
            let ao = crate::mesh::AdaptOptions {
                margin: a.margin,
                max_edge: a.max_edge,
                min_angle: a.min_angle,
                grid,
                extra_points: Vec::new(),
            };
            Mesh::landmark_adapted(&sources, size, &ao)
                .with_context(|| format!("cannot build a landmark mesh from {}", l.display()))?
                .mesh
        }
        (Some(p), None, None, None) => {
            let mut pts = read_points_csv(&read_text(p)?, &p.display().to_string())?;
            match a.outline {
                None => Mesh::delaunay(&pts, opts),
                Some(o) => {
                    let outline_pts = read_points_csv(&read_text(o)?, &o.display().to_string())?;
                    let first = pts.len();
                    pts.extend(outline_pts.iter().copied());
                    let idx: Vec<usize> = (first..pts.len()).collect();
                    Mesh::constrained_delaunay(&pts, &idx, opts)
                }
            }
            .with_context(|| format!("cannot build a mesh from {}", p.display()))?
        }
        (None, Some(g), None, None) => {
            let (c, r) = pair(g, "--grid", 'x')?;
            if c < 1.0 || r < 1.0 || c.fract() != 0.0 || r.fract() != 0.0 || c * r > 1e6 {
                bail!("--grid: expected COLSxROWS with whole numbers of cells, e.g. 6x4");
            }
            let (w, h) =
                pair(a.size.ok_or_else(|| anyhow!("--grid needs --size W,H"))?, "--size", ',')?;
            if w <= 0.0 || h <= 0.0 {
                bail!("--size: width and height must be positive");
            }
            Mesh::grid(c as usize, r as usize, w, h, opts)?
        }
        (None, None, Some(o), None) => Mesh::from_obj(&read_text(o)?, opts)
            .with_context(|| format!("cannot read the reference mesh {}", o.display()))?,
        _ => bail!("give exactly one of --points, --grid, --obj or --landmarks"),
    };
    let mut spline = Spline::identity(mesh, a.degree)?;
    if let Some(z) = a.z_range {
        let (lo, hi) = z.split_once(',').ok_or_else(|| anyhow!("--z-range: expected A,B"))?;
        let (lo, hi) = (
            parse_rat(lo).map_err(|e| anyhow!("--z-range: {e}"))?,
            parse_rat(hi).map_err(|e| anyhow!("--z-range: {e}"))?,
        );
        if lo >= hi {
            bail!("--z-range: need A < B");
        }
        let n = spline.num_points();
        spline.set_z_layers(Some(ZLayers {
            z0: vec![lo.clone(); n],
            z1: vec![hi.clone(); n],
            range: [lo, hi],
        }));
    }
    write_atomic(a.output, deformation::to_string(&spline, None).as_bytes())?;
    let m = spline.mesh();
    let snap = m.snap_report();
    writeln!(
        std::io::stdout(),
        "identity deformation of degree {}: {} vertices, {} triangles, {} control points, {} C1 conditions\nsnapped to 1/{}: {} vertices moved, at most {:.3e}\n-> {}",
        spline.degree(),
        m.num_vertices(),
        m.num_triangles(),
        spline.num_points(),
        spline.quads().len(),
        snap.grid,
        snap.moved,
        snap.max_shift,
        a.output.display()
    )?;
    Ok(())
}

fn load(path: &Path) -> Result<(Spline, Option<LastEdit>)> {
    let text = read_text(path)?;
    deformation::from_str(&text)
        .with_context(|| format!("cannot read deformation {}", path.display()))
}

fn rats(v: &Value, what: &str) -> Result<Vec<Rat>> {
    let arr = v.as_array().ok_or_else(|| anyhow!("{what}: expected an array of numbers"))?;
    arr.iter()
        .map(|x| {
            let t = match x {
                Value::Number(n) => n.to_string(),
                Value::String(s) => s.clone(),
                _ => bail!("{what}: `{x}` is not a number"),
            };
            parse_rat(&t).map_err(|e| anyhow!("{what}: {e}"))
        })
        .collect()
}

fn unsolvable(e: &EditError) -> bool {
    matches!(
        e,
        EditError::Ecles(
            EclesError::NotWeaklySolvable { .. } | EclesError::NotStronglySolvable { .. }
        )
    )
}

/// Applies one operation of an edit script.
fn apply_op(ed: &mut Editor, op: &Value, k: usize) -> Result<LastEdit> {
    let ctx = |m: String| anyhow!("operation {k}: {m}");
    let o = op.as_object().ok_or_else(|| ctx("expected an object".into()))?;
    if o.get("op").and_then(Value::as_str) == Some("constrain") {
        return add_constraints(ed, o, k).map(|()| LastEdit::default());
    }
    let anchors: Vec<usize> = match o.get("anchors") {
        Some(Value::Array(a)) => a
            .iter()
            .map(|x| {
                x.as_u64()
                    .map(|u| u as usize)
                    .ok_or_else(|| ctx(format!("anchor `{x}` is not a point index")))
            })
            .collect::<Result<_>>()?,
        Some(Value::Object(near)) => {
            let list = near
                .get("near")
                .and_then(Value::as_array)
                .ok_or_else(|| ctx("anchors: expected {\"near\": [[x, y], ...]}".into()))?;
            let pos: Vec<[f64; 2]> = list
                .iter()
                .map(|p| {
                    let v = p
                        .as_array()
                        .filter(|a| a.len() == 2)
                        .and_then(|a| Some([a[0].as_f64()?, a[1].as_f64()?]));
                    v.ok_or_else(|| ctx(format!("near: `{p}` is not [x, y]")))
                })
                .collect::<Result<_>>()?;
            let mut idx = ed.nearest_points(&pos);
            idx.dedup();
            idx
        }
        _ => {
            return Err(ctx(
                "missing \"anchors\" (point indices or {\"near\": [[x, y], ...]})".into()
            ))
        }
    };
    let derived: Vec<usize> = match o.get("derived") {
        None | Some(Value::Null) => Vec::new(),
        Some(Value::Array(a)) => a
            .iter()
            .map(|x| {
                x.as_u64()
                    .map(|u| u as usize)
                    .ok_or_else(|| ctx(format!("derived `{x}` is not a point index")))
            })
            .collect::<Result<_>>()?,
        Some(x) => return Err(ctx(format!("derived: expected an array, found {x}"))),
    };
    let hood = match o.get("neighborhood") {
        None | Some(Value::Null) => Neighborhood::Radius(2),
        Some(Value::String(s)) if s == "all" => Neighborhood::All,
        Some(Value::Number(n)) if n.as_u64().is_some() => {
            Neighborhood::Radius(n.as_u64().expect("the match guard checked as_u64") as usize)
        }
        Some(x) => {
            return Err(ctx(format!("neighborhood: expected a whole number or \"all\", found {x}")))
        }
    };
    let mode: Mode = match o.get("mode") {
        None | Some(Value::Null) => Mode::Xy,
        Some(Value::String(s)) => s.parse().map_err(ctx)?,
        Some(x) => return Err(ctx(format!("mode: expected \"xy\", \"z0\" or \"z1\", found {x}"))),
    };
    let kind = o
        .get("op")
        .and_then(Value::as_str)
        .ok_or_else(|| ctx("missing \"op\" (translate, rotate, scale or constrain)".into()))?;
    let run = |ed: &mut Editor| -> Result<(), EditError> {
        ed.select(&anchors, &derived, &hood, mode)?;
        Ok(())
    };
    let wrap = |e: EditError| -> anyhow::Error {
        let code = if unsolvable(&e) { EXIT_UNSOLVABLE } else { EXIT_INPUT };
        Exit { code, message: format!("operation {k} ({kind}): {e}"), printed: false }.into()
    };
    run(ed).map_err(wrap)?;
    let get = |key: &str| o.get(key).ok_or_else(|| ctx(format!("{kind} needs \"{key}\"")));
    match kind {
        "translate" => {
            let by = rats(get("by")?, "by")?;
            ed.translate(&by).map_err(wrap)?;
        }
        "rotate" => {
            let c = rats(get("center")?, "center")?;
            if c.len() != 2 {
                return Err(ctx("center: expected [x, y]".into()));
            }
            let angle = get("angle")?
                .as_f64()
                .ok_or_else(|| ctx("angle: expected a number (radians)".into()))?;
            ed.rotate([c[0].clone(), c[1].clone()], angle).map_err(wrap)?;
        }
        "scale" => {
            let c = rats(get("center")?, "center")?;
            let f = rats(&json!([get("factor")?]), "factor")?;
            ed.scale(&c, &f[0]).map_err(wrap)?;
        }
        other => return Err(ctx(format!("unknown op `{other}` (use translate, rotate or scale)"))),
    }
    let sel = ed.selection().expect("select succeeded above, so a selection is set");
    Ok(LastEdit { anchors: sel.anchors.clone(), derived: sel.derived.clone() })
}

/// The `constrain` operation: `pin` (indices), `horizontal` / `vertical` (lists of index
/// lists), `equal_displacement` (list of `[a, b]` pairs).
fn add_constraints(ed: &mut Editor, o: &serde_json::Map<String, Value>, k: usize) -> Result<()> {
    use crate::edit::extra::Extra;
    let fail = |m: String| -> anyhow::Error {
        Exit {
            code: EXIT_INPUT,
            message: format!("operation {k} (constrain): {m}"),
            printed: false,
        }
        .into()
    };
    let idx_list = |v: &Value, what: &str| -> Result<Vec<usize>> {
        v.as_array()
            .ok_or_else(|| fail(format!("{what}: expected an array of point indices")))?
            .iter()
            .map(|x| {
                x.as_u64()
                    .map(|u| u as usize)
                    .ok_or_else(|| fail(format!("{what}: `{x}` is not a point index")))
            })
            .collect()
    };
    let lists = |key: &str| -> Result<Vec<Vec<usize>>> {
        match o.get(key) {
            None => Ok(Vec::new()),
            Some(Value::Array(a)) => a.iter().map(|l| idx_list(l, key)).collect(),
            Some(x) => Err(fail(format!("{key}: expected an array of index lists, found {x}"))),
        }
    };
    let mut new = Vec::new();
    let pts = ed.spline().points();
    if let Some(p) = o.get("pin") {
        for i in idx_list(p, "pin")? {
            new.push(Extra::pin(i, pts).map_err(|e| fail(e.to_string()))?);
        }
    }
    for (key, axis) in [("horizontal", 1), ("vertical", 0)] {
        for l in lists(key)? {
            new.push(Extra::line(l, axis, pts).map_err(|e| fail(e.to_string()))?);
        }
    }
    for l in lists("equal_displacement")? {
        if l.len() != 2 {
            return Err(fail("equal_displacement: each entry is [a, b]".into()));
        }
        new.push(Extra::equal_displacement(l[0], l[1], pts).map_err(|e| fail(e.to_string()))?);
    }
    if new.is_empty() {
        return Err(fail(
            "no constraint given (pin, horizontal, vertical or equal_displacement)".into(),
        ));
    }
    for e in new {
        ed.add_constraint(e).map_err(|e| fail(e.to_string()))?;
    }
    Ok(())
}

/// Applies an edit script (JSON text: an array of operations) to `ed`, writing one progress
/// line per operation to `log`. Errors name `source` (the script file) and the operation
/// index; an unsolvable operation carries [`EXIT_UNSOLVABLE`]. Returns the number of
/// operations and the anchors / derived points of the last move.
pub fn run_script(
    ed: &mut Editor,
    text: &str,
    source: &str,
    log: &mut dyn Write,
) -> Result<(usize, Option<LastEdit>)> {
    let ops: Value = serde_json::from_str(text).map_err(|e| {
        anyhow!(
            "{source}, line {}: not valid JSON ({e}); an edit script is a JSON array of operations",
            e.line()
        )
    })?;
    let ops = ops.as_array().ok_or_else(|| {
        anyhow!(
            "{source}: expected a JSON array of operations, e.g. [{{\"op\": \"translate\", ...}}]"
        )
    })?;
    let mut last = None;
    for (k, op) in ops.iter().enumerate() {
        let l = apply_op(ed, op, k).map_err(|e| match e.downcast::<Exit>() {
            Ok(x) => Exit { message: format!("{source}: {}", x.message), ..x }.into(),
            Err(e) => {
                let text = super::error_text(&e);
                if text.starts_with("operation ") {
                    anyhow!("{source}: {text}")
                } else {
                    anyhow!("{source}: operation {k}: {text}")
                }
            }
        })?;
        let Some(sel) = ed.selection() else {
            writeln!(log, "operation {k}: {} constraints in force", ed.constraints().len())?;
            continue;
        };
        writeln!(
            log,
            "operation {k}: {} anchors, {} derived, {} relevant conditions (rank {}), {}",
            l.anchors.len(),
            l.derived.len(),
            sel.session().relevant().len(),
            sel.session().rank(),
            if sel.strong { "strongly solvable" } else { "weakly solvable" }
        )?;
        last = Some(l);
    }
    Ok((ops.len(), last))
}

/// `trimorph edit DEF --script EDITS -o OUT`.
pub fn edit(def: &Path, script: &Path, output: &Path, bounded: Option<u32>) -> Result<()> {
    if bounded.is_some_and(|b| !(8..=62).contains(&b)) {
        bail!("--bounded-bits must be between 8 and 62");
    }
    let (spline, _) = load(def)?;
    let extras = deformation::constraints_from_str(&read_text(def)?, &spline)
        .with_context(|| format!("cannot read the constraints of {}", def.display()))?;
    let text = read_text(script)?;
    let mut ed = Editor::new(spline);
    if let Err(e) = ed.set_bounded(bounded) {
        eprintln!("note: {e}; keeping exact values unbounded");
    }
    for e in extras {
        ed.add_constraint(e).context("a stored constraint does not hold")?;
    }
    let mut out = std::io::stdout();
    let (n_ops, last) = run_script(&mut ed, &text, &script.display().to_string(), &mut out)?;
    ed.spline().check_c1().context("internal error: the edit broke C1")?;
    // The editor's bound on coordinates (`trimorph editor` refuses the same with 422).
    if let Some(what) = crate::server::doc::absurd_point(ed.spline()) {
        return Err(Exit {
            code: super::EXIT_INPUT,
            message: format!(
                "{}: after the edits {what}, beyond {} pixels: refused (nothing written)",
                script.display(),
                crate::server::doc::MAX_COORD
            ),
            printed: false,
        }
        .into());
    }
    write_atomic(
        output,
        deformation::to_string_with(ed.spline(), last.as_ref(), ed.constraints()).as_bytes(),
    )?;
    writeln!(out, "{n_ops} operations applied; C1 holds exactly -> {}", output.display())?;
    let cert = certify(ed.spline(), &CertifyOptions::default());
    writeln!(out, "{}", det_j_line(&cert))?;
    if !cert.fold_free {
        eprintln!(
            "warning: {} is not certified fold-free (det J lower bound {}, sampled minimum {}): folding triangles {:?}, undecided triangles {:?}",
            output.display(),
            cert.lower_bound,
            cert.sampled_min,
            cert.folding,
            cert.undecided
        );
    }
    Ok(())
}

/// The first control point with a coordinate that is not a finite `f64` (an exact value
/// beyond the `f64` range): `(point, axis, value)`.
pub fn non_finite_point(s: &Spline) -> Option<(usize, usize, f64)> {
    (0..s.num_points()).find_map(|p| {
        let q = s.point_f64(p);
        (0..2).find(|&a| !q[a].is_finite()).map(|a| (p, a, q[a]))
    })
}

/// One line with the certificate's numbers: the sampled minimum, the certified lower bound
/// and whether phi is certified fold-free (with the folding and undecided triangles).
pub fn det_j_line(c: &DetJ) -> String {
    let list = |v: &[usize]| {
        let shown: Vec<String> = v.iter().take(20).map(|t| t.to_string()).collect();
        let more = if v.len() > 20 { format!(", ... ({} in all)", v.len()) } else { String::new() };
        format!("[{}{more}]", shown.join(", "))
    };
    let verdict = if c.fold_free {
        "certified fold-free".to_string()
    } else {
        format!(
            "NOT certified fold-free: folding triangles {}, undecided triangles {}",
            list(&c.folding),
            list(&c.undecided)
        )
    };
    format!(
        "det J: sampled minimum {} (level-{} lattice of every triangle), certified lower bound {}; {verdict}",
        c.sampled_min, SAMPLE_LEVEL, c.lower_bound
    )
}

/// The `trimorph check` report of a spline.
pub fn check_report(s: &Spline, samples_per_side: usize) -> Value {
    let res = s.c1_residuals();
    let nonzero = res.iter().filter(|r| !r[0].is_zero() || !r[1].is_zero()).count();
    let max_res = res
        .iter()
        .flat_map(|r| r.iter().cloned())
        .map(|r| if r < Rat::zero() { -r } else { r })
        .max()
        .unwrap_or_else(Rat::zero);
    let m = s.mesh();
    let cache = s.eval_cache();
    let k = samples_per_side.max(1);
    // The --samples scan counts folded samples; the minimum reported is the common one of
    // the certificate (the same number as `field --jacobian`, `edit` and the editor).
    let (mut folds, mut samples) = (0usize, 0usize);
    for t in 0..m.num_triangles() {
        for i in 0..=k {
            for j in 0..=k - i {
                let b = [i as f64 / k as f64, j as f64 / k as f64, (k - i - j) as f64 / k as f64];
                let jm = cache.jacobian(t, b);
                let det = jm[0][0] * jm[1][1] - jm[0][1] * jm[1][0];
                samples += 1;
                if det <= 0.0 {
                    folds += 1;
                }
            }
        }
    }
    let cert = certify(s, &CertifyOptions::default());
    let worst = cert.worst.map(|(t, p)| json!({"triangle": t, "point": p}));
    json!({
        "degree": s.degree(),
        "vertices": m.num_vertices(),
        "triangles": m.num_triangles(),
        "interior_edges": m.num_interior_edges(),
        "control_points": s.num_points(),
        "c1_conditions": s.quads().len(),
        "c1_nonzero_residuals": nonzero,
        "c1_max_abs_residual": rat_to_string(&max_res),
        "c1_holds": nonzero == 0,
        "c1_residuals": res.iter().map(|r| [rat_to_string(&r[0]), rat_to_string(&r[1])]).collect::<Vec<_>>(),
        "jacobian_samples": samples,
        "min_jacobian_det": cert.sampled_min,
        "min_jacobian_det_at": worst,
        "fold_samples": folds,
        "folds": folds > 0 || !cert.folding.is_empty(),
        "det_j_lower_bound": cert.lower_bound,
        "fold_free": cert.fold_free,
        "folding_triangles": cert.folding,
        "undecided_triangles": cert.undecided,
        "z_layers": s.z_layers().is_some(),
    })
}

/// `trimorph check DEF`: exit 0 when C1 holds exactly, 1 otherwise.
pub fn check(def: &Path, samples: usize) -> Result<()> {
    // The scan costs samples^2 evaluations per triangle: beyond this it never finishes.
    const MAX_SAMPLES: usize = 1000;
    if samples > MAX_SAMPLES {
        bail!("--samples {samples}: at most {MAX_SAMPLES} samples per triangle side");
    }
    let text = read_text(def)?;
    let (s, _) = deformation::from_str_unchecked(&text)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    if let Some((p, a, v)) = non_finite_point(&s) {
        bail!(
            "{}: control point {p}: its {} coordinate {v} is not a finite double (the exact value is beyond the f64 range); correct that point",
            def.display(),
            ["x", "y"][a]
        );
    }
    let rep = check_report(&s, samples);
    writeln!(std::io::stdout(), "{}", serde_json::to_string_pretty(&rep)?)?;
    if rep["c1_holds"] != json!(true) {
        return Err(Exit {
            code: EXIT_INPUT,
            message: format!("{}: C1 conditions do not hold", def.display()),
            printed: false,
        }
        .into());
    }
    Ok(())
}

/// `trimorph render DEF -o OUT.png [--background IMG] [--show LAYERS] [--size W,H]`.
pub fn render(
    def: &Path,
    output: &Path,
    background: Option<&Path>,
    show: &str,
    size: &str,
) -> Result<()> {
    use crate::render::deformation as rd;
    let (s, last) = load(def)?;
    let mut opts = rd::RenderOptions::parse_show(show)?;
    let (w, h) = pair(size, "--size", ',')?;
    if w < 16.0 || h < 16.0 || w > 16384.0 || h > 16384.0 || w.fract() != 0.0 || h.fract() != 0.0 {
        bail!("--size: width and height must be whole numbers from 16 to 16384");
    }
    (opts.width, opts.height) = (w as u32, h as u32);
    let bg = background.map(rd::load_background).transpose()?;
    let pm = rd::render(&s, last.as_ref(), bg.as_ref(), &opts)?;
    rd::save_png(&pm, output)?;
    writeln!(std::io::stdout(), "{}x{} -> {}", pm.width(), pm.height(), output.display())?;
    Ok(())
}
