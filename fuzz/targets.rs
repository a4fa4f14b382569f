//! The bodies of the fuzz targets, shared by the fuzz crate (`fuzz/fuzz_targets/*.rs`) and
//! the regression test (`tests/fuzz_regressions.rs`), so a saved input replays through
//! exactly the code the fuzzer ran. Each function must return (errors are fine) and never
//! panic; `ldu_rebuild` also asserts the exact rebuild of the matrix from its factors.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use trimorph::exact::{Int, Ldu, LduOptions, Pivoting, Simplification, SparseIntMatrix};

/// The names of all targets, in the order of `fuzz/Cargo.toml`.
pub const TARGETS: &[&str] = &[
    "deformation_json",
    "solve_json",
    "model_obj",
    "model_ply",
    "landmarks_csv",
    "landmarks_bigwarp",
    "edit_script",
    "ldu_rebuild",
    "image_decode_warp",
    "editor_api",
    "landmarks_points",
    "ngff_metadata",
];

/// Runs the target called `name` on `data`.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "deformation_json" => deformation_json(data),
        "solve_json" => solve_json(data),
        "model_obj" => model_obj(data),
        "model_ply" => model_ply(data),
        "landmarks_csv" => landmarks_csv(data),
        "landmarks_bigwarp" => landmarks_bigwarp(data),
        "edit_script" => edit_script(data),
        "ldu_rebuild" => ldu_rebuild(data),
        "image_decode_warp" => image_decode_warp(data),
        "editor_api" => editor_api(data),
        "landmarks_points" => landmarks_points(data),
        "ngff_metadata" => ngff_metadata(data),
        other => panic!("unknown fuzz target {other}"),
    }
}

fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}

/// A deformation file: parse, and when it loads, serialize it and parse it back.
pub fn deformation_json(data: &[u8]) {
    let Some(t) = text(data) else { return };
    if let Ok((s, last)) = trimorph::io::deformation::from_str(t) {
        let again = trimorph::io::deformation::to_string(&s, last.as_ref());
        let (s2, _) = trimorph::io::deformation::from_str(&again)
            .expect("a written deformation must load again");
        assert_eq!(s.points(), s2.points(), "the round trip changed the control points");
        let _ = trimorph::io::deformation::constraints_from_str(t, &s);
    }
}

/// A `trimorph solve` problem: parse and solve.
pub fn solve_json(data: &[u8]) {
    let Some(t) = text(data) else { return };
    if let Ok(p) = trimorph::ecles::problem::Problem::from_json(t) {
        if let Ok(sol) = p.solve() {
            let _ = sol.to_json_text();
        }
    }
}

/// An OBJ model (the reader of `model bind`, `render --model`, `warp --model`).
pub fn model_obj(data: &[u8]) {
    if let Ok(m) = trimorph::io::model::parse_model(data, Path::new("fuzz.obj")) {
        let _ = m.validate();
    }
}

/// A PLY model, read both as a model and as a coloured mesh (`warp --mesh`).
pub fn model_ply(data: &[u8]) {
    if let Ok(m) = trimorph::io::model::parse_model(data, Path::new("fuzz.ply")) {
        let _ = m.validate();
    }
    let _ = trimorph::io::colormesh::read_ply(data, Path::new("fuzz.ply"));
}

/// Landmark CSV (`name,src_x,src_y,dst_x,dst_y[,weight]`), with a write / read round trip.
pub fn landmarks_csv(data: &[u8]) {
    use trimorph::fit::landmarks as lm;
    let Some(t) = text(data) else { return };
    if let Ok(l) = lm::parse_csv(t) {
        if let Ok(out) = lm::to_csv(&l) {
            let back = lm::parse_csv(&out).expect("written landmarks must load again");
            assert_eq!(back.len(), l.len());
        }
    }
}

/// Fiji BigWarp landmark CSV, both column orders.
pub fn landmarks_bigwarp(data: &[u8]) {
    use trimorph::fit::landmarks as lm;
    let Some(t) = text(data) else { return };
    for swap in [false, true] {
        if let Ok(l) = lm::parse_bigwarp(t, swap) {
            if let Ok(out) = lm::to_bigwarp(&l, swap) {
                let back = lm::parse_bigwarp(&out, swap).expect("written landmarks must load");
                assert_eq!(back.len(), l.len());
            }
        }
    }
    let _ = lm::parse(t, lm::LandmarkFormat::detect(Some("csv"), t));
}

/// An edit script applied to a small quintic spline over a 2 x 2 grid of 8 x 8 pixels.
pub fn edit_script(data: &[u8]) {
    use trimorph::edit::Editor;
    use trimorph::mesh::{Mesh, MeshOptions};
    use trimorph::spline::Spline;
    let Some(t) = text(data) else { return };
    let mesh = Mesh::grid(2, 2, 8.0, 8.0, MeshOptions { grid: 16 }).expect("grid mesh");
    let spline = Spline::identity(mesh, 5).expect("identity spline");
    let mut ed = Editor::new(spline);
    ed.set_bounded(Some(24)).expect("bounded editing");
    let before = ed.spline().clone();
    let Ok(script) = trimorph::edit::script::Script::from_json_str(t) else { return };
    match script.run(&mut ed) {
        Ok(_) => ed.spline().check_c1().expect("an accepted edit keeps C1 exactly"),
        Err(_) => {
            assert!(ed.spline().points() == before.points(), "a refused script changes nothing")
        }
    }
}

/// Decodes bytes into a small integer matrix and its options: byte 0 = rows (1..=8), byte 1
/// = cols (1..=8), byte 2 = options, then one signed byte per entry (missing entries are 0;
/// entries are scaled by byte 3 for larger values).
pub fn ldu_matrix(data: &[u8]) -> Option<(SparseIntMatrix, LduOptions)> {
    let (&r, rest) = data.split_first()?;
    let (&c, rest) = rest.split_first()?;
    let (&o, rest) = rest.split_first()?;
    let (&scale, rest) = rest.split_first()?;
    let (m, n) = (1 + r as usize % 8, 1 + c as usize % 8);
    let simplification =
        [Simplification::None, Simplification::Gcd, Simplification::Turner][o as usize % 3];
    let pivoting = [Pivoting::Markowitz, Pivoting::SmallestMagnitude, Pivoting::SymmetricMarkowitz]
        [(o as usize / 3) % 3];
    let mult = 1 + (scale as i64 % 16).pow(4);
    // Symmetric pivoting is meant for symmetric matrices: mirror the lower triangle.
    let sym = pivoting == Pivoting::SymmetricMarkowitz;
    let n = if sym { m } else { n };
    let entry = |i: usize, j: usize| {
        let (i, j) = if sym && j > i { (j, i) } else { (i, j) };
        *rest.get(i * n + j).unwrap_or(&0) as i8 as i64 * mult
    };
    let rows = (0..m)
        .map(|i| {
            (0..n)
                .filter_map(|j| {
                    let v = entry(i, j);
                    (v != 0).then(|| (j, Int::from(v)))
                })
                .collect()
        })
        .collect();
    let a = SparseIntMatrix::from_rows(n, rows).ok()?;
    Some((a, LduOptions { simplification, pivoting }))
}

/// The exact fraction-free LDU: factor a small integer matrix and rebuild it exactly.
pub fn ldu_rebuild(data: &[u8]) {
    let Some((a, opts)) = ldu_matrix(data) else { return };
    let f = Ldu::factor(&a, opts);
    f.sanity_check().expect("the factors' invariants hold");
    assert!(f.reconstructs(&a), "A is not rebuilt from its factors: {a:?} with {opts:?}");
    assert!(f.rank() <= a.rows().min(a.cols()));
}

/// The memory budget of `image_decode_warp`: an image that needs more is refused, not
/// allocated (the fuzzer's own limit, `-rss_limit_mb`, is far above it).
pub const IMAGE_BUDGET: u64 = 256 << 20;

/// The largest output of `image_decode_warp` (the first page is cropped to it).
pub const WARP_SIZE: u32 = 48;

/// A mild deformation over 64 x 64 pixels: a quintic spline on a 2 x 2 grid whose centre
/// vertex (32, 32) is translated by (1, 1/2) exactly, with its radius-2 neighbourhood.
pub fn mild_deformation() -> &'static trimorph::spline::Spline {
    static S: OnceLock<trimorph::spline::Spline> = OnceLock::new();
    S.get_or_init(|| {
        use trimorph::edit::Editor;
        use trimorph::mesh::{Mesh, MeshOptions};
        let mesh = Mesh::grid(2, 2, 64.0, 64.0, MeshOptions::default()).expect("grid mesh");
        let c = (0..mesh.num_vertices())
            .find(|&v| mesh.vertex(v) == [32.0, 32.0])
            .expect("a centre vertex");
        let mut ed =
            Editor::new(trimorph::spline::Spline::identity(mesh, 5).expect("identity spline"));
        let script = format!(r#"[{{"op":"translate","anchors":[{c}],"by":[1,"1/2"]}}]"#);
        trimorph::edit::script::Script::from_json_str(&script)
            .expect("script")
            .run(&mut ed)
            .expect("a mild translation is accepted");
        ed.into_spline()
    })
}

/// An image in memory (PNG, JPEG, GIF, TIFF, PNM, as `trimorph warp` reads it:
/// [`trimorph::io::raster::decode_stack`]) under a 256 MiB budget; when it decodes, its
/// first page (cropped to at most 48 x 48) is warped through [`mild_deformation`]. The
/// output must have the page's size and pixel type, and a refused image must be refused for
/// a reason (not a panic, not an allocation beyond the budget).
pub fn image_decode_warp(data: &[u8]) {
    use trimorph::warp::{warp_pages, Interp, WarpOptions};
    trimorph::memory::set_limit(Some(IMAGE_BUDGET));
    let Ok(stack) = trimorph::io::raster::decode_stack(data, Path::new("fuzz.img")) else {
        return;
    };
    assert!(!stack.pages.is_empty(), "a decoded stack has a page");
    let page = &stack.pages[0];
    let (w, h) = (page.width().min(WARP_SIZE), page.height().min(WARP_SIZE));
    let page = page.crop_imm(0, 0, w, h);
    let interp = [Interp::Nearest, Interp::Bilinear, Interp::Bicubic][data.len() % 3];
    // A background the page's samples hold (`warp::check_background`).
    let background = match page.color() {
        image::ColorType::Rgb32F | image::ColorType::Rgba32F => 0.5,
        _ => 128.0,
    };
    let opts = WarpOptions { interp, background, ..Default::default() };
    let (out, _) = warp_pages(mild_deformation(), std::slice::from_ref(&page), &opts, &|_| {})
        .expect("a decoded page warps");
    assert_eq!(out.len(), 1, "one page in, one page out");
    assert_eq!((out[0].width(), out[0].height()), (w, h), "the output has the page's size");
    assert_eq!(out[0].color(), page.color(), "the output has the page's pixel type");
}

/// The editor API's routes, as `editor_api` picks them: line byte `b'a' + i` (mod the
/// length) is `EDITOR_ROUTES[i]`.
pub const EDITOR_ROUTES: &[(&str, &str)] = &[
    ("GET", "/api/state"),
    ("GET", "/api/geometry"),
    ("GET", "/api/image.png"),
    ("GET", "/api/jacobian.png"),
    ("GET", "/api/warp"),
    ("POST", "/api/pick"),
    ("POST", "/api/select"),
    ("POST", "/api/update"),
    ("POST", "/api/clear"),
    ("POST", "/api/undo"),
    ("POST", "/api/redo"),
    ("POST", "/api/save"),
    ("POST", "/api/stat"),
    ("POST", "/api/load"),
    ("POST", "/api/export"),
    ("POST", "/api/refit"),
    ("GET", "/api/landmarks"),
    ("POST", "/api/landmarks/add"),
    ("POST", "/api/landmarks/move"),
    ("POST", "/api/landmarks/delete"),
    ("POST", "/api/landmarks/import"),
    ("POST", "/api/landmarks/export"),
    ("GET", "/"),
    ("POST", "/api/nothing"),
];

/// At most this many requests per input.
pub const EDITOR_MAX_REQUESTS: usize = 48;

/// The folder of an `editor_api` input's document: one per process and thread (the
/// regression test replays inputs on several threads at once), made afresh for each input
/// and removed after it.
fn editor_root() -> PathBuf {
    let thread = format!("{:?}", std::thread::current().id());
    let thread: String = thread.chars().filter(char::is_ascii_digit).collect();
    std::env::temp_dir().join(format!("trimorph-fuzz-editor-{}-{thread}", std::process::id()))
}

/// The files each `editor_api` input starts with: a landmark CSV, a deformation over the
/// doc's mesh (the mild one scaled: same layout) and one over another mesh.
fn editor_files() -> &'static [(&'static str, String)] {
    static F: OnceLock<Vec<(&'static str, String)>> = OnceLock::new();
    F.get_or_init(|| {
        use trimorph::mesh::{Mesh, MeshOptions};
        use trimorph::spline::Spline;
        let other = Spline::identity(
            Mesh::grid(1, 1, 16.0, 16.0, MeshOptions::default()).expect("mesh"),
            3,
        )
        .expect("spline");
        vec![
            (
                "pairs.csv",
                "name,src_x,src_y,dst_x,dst_y\nA,8,8,9,8.5\nB,24,20,24,21\nC,16,28,15,28\n".into(),
            ),
            ("same.json", trimorph::io::deformation::to_string(&editor_spline(), None)),
            ("other.json", trimorph::io::deformation::to_string(&other, None)),
        ]
    })
}

/// The doc's spline: quintic on a 2 x 2 grid of 32 x 32 pixels.
fn editor_spline() -> trimorph::spline::Spline {
    use trimorph::mesh::{Mesh, MeshOptions};
    let mesh = Mesh::grid(2, 2, 32.0, 32.0, MeshOptions::default()).expect("grid mesh");
    trimorph::spline::Spline::identity(mesh, 5).expect("identity spline")
}

/// What a refused request must leave as it was: the state (without its timing), the
/// control points exactly, and the landmark pairs.
fn editor_snapshot(doc: &trimorph::server::doc::Doc) -> EditorSnapshot {
    let mut st = doc.state();
    st.last_update_ms = 0.0;
    // Debug text: equal for equal answers, NaN included (as the JSON's `null` was).
    (format!("{st:?}"), doc.spline().points().to_vec(), format!("{:?}", doc.pairs_json()))
}

/// The state and pairs as text, and the control points.
type EditorSnapshot = (String, Vec<Vec<trimorph::exact::Rat>>, String);

/// The doc's frame: a 24 x 24 gray gradient (a PGM, decoded as `trimorph editor` would).
fn editor_frame() -> trimorph::io::raster::Stack {
    let mut pgm = b"P5\n24 24\n255\n".to_vec();
    pgm.extend((0..24u32 * 24).map(|i| ((i % 24) * 10 + i / 24) as u8));
    trimorph::io::raster::decode_stack(&pgm, Path::new("frame.pgm")).expect("a gray frame")
}

/// The session of `editor_api`'s server: its token, and the port its `Host` names.
pub const EDITOR_TOKEN: &str = "fuzz-token";
/// See [`EDITOR_TOKEN`].
pub const EDITOR_PORT: u16 = 8;

/// How a line's request is sent (the pick byte's group of [`EDITOR_ROUTES`]`.len()` values,
/// so `a` ... `x` are plain requests).
const EDITOR_VARIANTS: usize = 8;

/// `b` with every byte outside a URI's query characters percent-encoded.
fn query_escape(b: &[u8]) -> String {
    b.iter()
        .map(|&c| {
            if c.is_ascii_alphanumeric() || b"-._~=&;,:/?@!$'()*+".contains(&c) {
                (c as char).to_string()
            } else {
                format!("%{c:02X}")
            }
        })
        .collect()
}

/// The bytes of one request to `path` with `body` (for a GET: the query) sent as `variant`
/// says, and the status the gate must answer, if it must refuse.
fn editor_request(variant: usize, method: &str, path: &str, body: &[u8]) -> (Vec<u8>, Option<u16>) {
    let host = format!("127.0.0.1:{EDITOR_PORT}");
    let mut target = path.to_string();
    let mut body = body.to_vec();
    if method == "GET" {
        if !body.is_empty() && std::str::from_utf8(&body).is_ok() {
            target = format!("{path}?{}", query_escape(&body));
        }
        body.clear();
    }
    let api = path.starts_with("/api/");
    let mut head = vec![format!("{method} {target} HTTP/1.1"), format!("Host: {host}")];
    let mut expect = None;
    match variant {
        2 => expect = api.then_some(401),
        3 => {
            head.push("Origin: http://evil.example".into());
            expect = Some(403);
        }
        5 => {
            head.push("Host: evil.example".into());
            expect = Some(400);
        }
        _ => {}
    }
    if variant != 2 {
        head.push(format!("X-Trimorph-Token: {EDITOR_TOKEN}"));
    }
    if variant == 4 && api && !body.is_empty() {
        head.push("Content-Type: text/plain".into());
        expect = expect.or(Some(415));
    } else {
        head.push("Content-Type: application/json".into());
    }
    let mut payload = Vec::new();
    if variant == 1 && !body.is_empty() {
        // Chunked, in pieces of 1, 2, 3, ... bytes.
        head.push("Transfer-Encoding: chunked".into());
        let (mut rest, mut n) = (&body[..], 1);
        while !rest.is_empty() {
            let (c, r) = rest.split_at(n.min(rest.len()));
            payload.extend(format!("{:x}\r\n", c.len()).bytes());
            payload.extend(c);
            payload.extend(b"\r\n");
            rest = r;
            n += 1;
        }
        payload.extend(b"0\r\n\r\n");
    } else {
        head.push(format!("Content-Length: {}", body.len()));
        payload = body;
    }
    if variant == 7 {
        head.push("Expect: 100-continue".into());
    } else {
        head.push("Connection: close".into());
    }
    let mut raw = head.join("\r\n").into_bytes();
    raw.extend(b"\r\n\r\n");
    raw.extend(payload);
    (raw, expect)
}

/// The status of a raw HTTP answer (the first one after any `100 Continue`); 0 when none.
fn editor_status(answer: &[u8]) -> u16 {
    let text = String::from_utf8_lossy(answer);
    text.match_indices("HTTP/1.1 ")
        .filter_map(|(i, _)| text[i + 9..].get(..3)?.parse().ok())
        .find(|&s| s != 100)
        .unwrap_or(0)
}

/// Requests to the editor's server (hyper's HTTP/1.1 parser, the gate of
/// [`trimorph::server::http`] and the handlers, through [`trimorph::server::serve_bytes`], in
/// memory) over a doc with a 24 x 24 frame, rooted in a per-process folder. Each line of the
/// input is one request: its first byte picks the route ([`EDITOR_ROUTES`], modulo their
/// number) and how it is sent (the byte's group: `a`-`x` plain, then chunked, without the
/// token, a foreign `Origin`, `text/plain`, two `Host` headers, raw, `Expect: 100-continue`);
/// the rest is the body as raw bytes (for a GET, the query). Raw: the rest of the line is
/// the connection's bytes, each `|` standing for CRLF. The gate's refusals must be the
/// expected statuses; a refused request (not 2xx) must leave the doc as it was; at the end
/// the spline must still be C1 exactly.
pub fn editor_api(data: &[u8]) {
    editor_api_statuses(data);
}

/// [`editor_api`], returning the status of each request (0: no answer).
pub fn editor_api_statuses(data: &[u8]) -> Vec<u16> {
    use trimorph::server::doc::Doc;
    let mut statuses = Vec::new();
    let root = &editor_root();
    let _ = std::fs::remove_dir_all(root);
    std::fs::create_dir_all(root).expect("the fuzz folder");
    for (name, text) in editor_files() {
        std::fs::write(root.join(name), text).expect("a start file");
    }
    let mut doc = Doc::new(editor_spline(), root);
    let frame = editor_frame().pages.swap_remove(0);
    doc.set_frame(PathBuf::from("frame.png"), frame).expect("a gray frame");
    let guard = trimorph::server::http::Guard::new(EDITOR_TOKEN.into(), EDITOR_PORT);
    for line in data.split(|&b| b == b'\n').take(EDITOR_MAX_REQUESTS) {
        let Some((&pick, body)) = line.split_first() else { continue };
        let k = pick.wrapping_sub(b'a') as usize;
        let (method, path) = EDITOR_ROUTES[k % EDITOR_ROUTES.len()];
        let variant = k / EDITOR_ROUTES.len() % EDITOR_VARIANTS;
        let (raw, expect) = if variant == 6 {
            let mut raw = Vec::with_capacity(body.len() + 8);
            for &b in body {
                match b {
                    b'|' => raw.extend(b"\r\n"),
                    b => raw.push(b),
                }
            }
            (raw, None)
        } else {
            editor_request(variant, method, path, body)
        };
        let before = editor_snapshot(&doc);
        let answer = trimorph::server::serve_bytes(&guard, &mut doc, &raw);
        let status = editor_status(&answer);
        statuses.push(status);
        let what = || String::from_utf8_lossy(&raw).into_owned();
        if variant != 6 {
            assert!(status != 0, "no answer to {}", what());
        }
        if let Some(e) = expect {
            assert_eq!(status, e, "the gate let through {}", what());
        }
        if !(200..300).contains(&status) {
            let after = editor_snapshot(&doc);
            assert!(
                before == after,
                "{} answered {status} ({}) but changed the doc:\nbefore {}\nafter  {}\npoints equal: {}",
                what(),
                String::from_utf8_lossy(&answer),
                before.0,
                after.0,
                before.1 == after.1
            );
        }
    }
    doc.spline().check_c1().expect("the spline stays C1 exactly");
    let _ = std::fs::remove_dir_all(root);
    statuses
}

/// Point files (`fit --landmarks-src/--landmarks-dst`, `morph`): the text read as each of
/// iBUG `.pts`, ITK point set and CSV `x,y`, and as format detection picks it. What is read
/// is at least one point, every coordinate finite.
pub fn landmarks_points(data: &[u8]) {
    use trimorph::fit::landmarks::{parse_points, PointFormat};
    let Some(t) = text(data) else { return };
    let detected = PointFormat::detect(None, t);
    for f in [PointFormat::Pts, PointFormat::Itk, PointFormat::Csv, detected] {
        if let Ok(pts) = parse_points(t, f) {
            assert!(!pts.is_empty(), "{f:?}: a point file read without points");
            assert!(pts.iter().flatten().all(|v| v.is_finite()), "{f:?}: a coordinate not finite");
        }
    }
}

/// An OME-Zarr store's metadata and one chunk, read by `io::ngff::read_image` (the reader
/// of `warp --image X.zarr`) under a 256 MiB memory budget. The input is split at its first
/// two zero bytes: the root group's metadata, the array `0`'s metadata, the chunk's bytes.
/// Its first byte picks Zarr v2 (odd: `.zattrs` with `.zgroup`, `0/.zarray`) or v3 (even:
/// `zarr.json`, `0/zarr.json`), and (bits 1-2) the dimensions, 2 to 5, of the chunk key
/// (`0/0.0`, `0/c/0/0`, ...) the chunk is written under.
/// The store is in a per-process (and per-thread) folder, made afresh for each input. A read
/// image has at least one page, all of the declared plane size.
pub fn ngff_metadata(data: &[u8]) {
    trimorph::memory::set_limit(Some(IMAGE_BUDGET));
    let Some(dir) = ngff_store(data) else { return };
    if let Ok(img) = trimorph::io::ngff::read_image(&dir) {
        assert!(!img.pages.is_empty(), "a read OME-Zarr image has a page");
        let (w, h) = (img.pages[0].width(), img.pages[0].height());
        assert!(img.pages.iter().all(|p| (p.width(), p.height()) == (w, h)), "planes differ");
    }
}

/// The store of an `ngff_metadata` input (see there), written afresh; `None` for no input.
pub fn ngff_store(data: &[u8]) -> Option<PathBuf> {
    let &first = data.first()?;
    let mut parts = data[1..].splitn(3, |&b| b == 0);
    let (root, array, chunk) =
        (parts.next().unwrap_or(&[]), parts.next().unwrap_or(&[]), parts.next().unwrap_or(&[]));
    let thread = format!("{:?}", std::thread::current().id());
    let thread: String = thread.chars().filter(char::is_ascii_digit).collect();
    let dir = std::env::temp_dir()
        .join(format!("trimorph-fuzz-ngff-{}-{thread}", std::process::id()))
        .join("img.zarr");
    let _ = std::fs::remove_dir_all(&dir);
    let dims = 2 + usize::from((first >> 1) % 4);
    let zeros = vec!["0"; dims];
    let key = if first % 2 == 1 {
        format!("0/{}", zeros.join("."))
    } else {
        format!("0/c/{}", zeros.join("/"))
    };
    std::fs::create_dir_all(dir.join(&key).parent().expect("a folder")).expect("scratch");
    let put = |rel: &str, bytes: &[u8]| std::fs::write(dir.join(rel), bytes).expect("write");
    if first % 2 == 1 {
        put(".zgroup", br#"{"zarr_format": 2}"#);
        put(".zattrs", root);
        put("0/.zarray", array);
    } else {
        put("zarr.json", root);
        put("0/zarr.json", array);
    }
    put(&key, chunk);
    Some(dir)
}
