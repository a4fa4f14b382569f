//! One editor drag step on the bundled scene (worm model in prisms over an 8x8-cell mesh of
//! a 511 x 511 frame, degree 5, 1681 control points): the API call `POST /api/update`
//! through [`trimorph::server::handle`], i.e. the exact ECLES update, the deformed model,
//! mesh polylines and control points, and the JSON answer; also in z1 mode, whose answer
//! adds the z values and the model in 3D; and a drag step with the live warp on (the update
//! plus the coarse inverse map `GET /api/warp`). The browser adds the HTTP round trip and the
//! redraw (measured by `tests/it/server/editor_e2e.rs`). Also the landmark pairs' residual
//! list and a pair move with 100 pairs.

use criterion::{criterion_group, criterion_main, Criterion};
use serde_json::json;
use std::hint::black_box;
use trimorph::server::doc::Doc;
use trimorph::server::handle;

fn bench(c: &mut Criterion) {
    let (s, model, frame) = trimorph::bundled::scene().unwrap();
    let dir = std::env::temp_dir();
    let mut g = c.benchmark_group("editor");
    g.sample_size(30);
    for radius in [2u64, 4] {
        let mut doc = Doc::new(s.clone(), &dir);
        doc.set_model("worm.obj".into(), model.clone()).unwrap();
        doc.set_frame("frame.png".into(), frame.clone()).unwrap();
        let p = doc.editor().nearest_points(&[[255.5, 255.5]])[0].index();
        let sel = json!({"anchors": [p], "radius": radius}).to_string();
        let r = handle(&mut doc, "POST", "/api/select", sel.as_bytes());
        assert_eq!(r.status, 200);
        let mut k = 0u32;
        g.bench_function(format!("drag_step_radius{radius}"), |b| {
            b.iter(|| {
                k += 1;
                let v = [f64::from(k % 50) * 0.25, -f64::from(k % 30) * 0.25];
                let body = json!({"op": "translate", "v": v}).to_string();
                let r = handle(&mut doc, "POST", "/api/update", body.as_bytes());
                assert_eq!(r.status, 200);
                black_box(r.body.len())
            })
        });
        // With the live warp on, a drag step is the update and the coarse inverse map the
        // page asks for after it (`GET /api/warp`, 8 px nodes over the 511 x 511 frame).
        g.bench_function(format!("drag_step_live_warp_radius{radius}"), |b| {
            b.iter(|| {
                k += 1;
                let v = [f64::from(k % 50) * 0.25, -f64::from(k % 30) * 0.25];
                let body = json!({"op": "translate", "v": v}).to_string();
                let r = handle(&mut doc, "POST", "/api/update", body.as_bytes());
                assert_eq!(r.status, 200);
                let w = handle(&mut doc, "GET", "/api/warp", b"");
                assert_eq!(w.status, 200);
                black_box(r.body.len() + w.body.len())
            })
        });
        // The drag-latency target is on the distribution of single steps (median <= 16 ms,
        // p90 <= 25 ms): 200 steps timed one by one, printed.
        let mut t: Vec<f64> = (0..200)
            .map(|_| {
                k += 1;
                let v = [f64::from(k % 50) * 0.25, -f64::from(k % 30) * 0.25];
                let body = json!({"op": "translate", "v": v}).to_string();
                let t0 = std::time::Instant::now();
                assert_eq!(handle(&mut doc, "POST", "/api/update", body.as_bytes()).status, 200);
                assert_eq!(handle(&mut doc, "GET", "/api/warp", b"").status, 200);
                t0.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        t.sort_by(f64::total_cmp);
        eprintln!(
            "editor/drag_step_live_warp_radius{radius}: 200 steps, median {:.2} ms, p90 {:.2} ms, max {:.2} ms",
            t[100], t[180], t[199]
        );
        g.bench_function(format!("select_radius{radius}"), |b| {
            b.iter(|| black_box(handle(&mut doc, "POST", "/api/select", sel.as_bytes()).status))
        });
        // A z1 drag: the answer also carries z0, z1 and the deformed model in 3D.
        let sel_z = json!({"anchors": [p], "radius": radius, "mode": "z1"}).to_string();
        assert_eq!(handle(&mut doc, "POST", "/api/select", sel_z.as_bytes()).status, 200);
        g.bench_function(format!("z1_drag_step_radius{radius}"), |b| {
            b.iter(|| {
                k += 1;
                let body = json!({"op": "translate", "v": [f64::from(k % 40) * 0.25]}).to_string();
                let r = handle(&mut doc, "POST", "/api/update", body.as_bytes());
                assert_eq!(r.status, 200);
                black_box(r.body.len())
            })
        });
    }
    // Landmark pairs: the residual list `GET /api/landmarks` (phi at every reference point)
    // and a move of one pair (`POST /api/landmarks/move`, which answers the list), 100 pairs.
    let mut doc = Doc::new(s.clone(), &dir);
    for k in 0..100u32 {
        let (x, y) = (20.0 + f64::from(k % 10) * 47.0, 20.0 + f64::from(k / 10) * 47.0);
        doc.add_pair(None, [x, y], [x + 1.5, y - 0.5]).unwrap();
    }
    g.bench_function("landmarks_list_100", |b| {
        b.iter(|| black_box(handle(&mut doc, "GET", "/api/landmarks", b"").body.len()))
    });
    let mut k = 0u32;
    g.bench_function("landmarks_move_100", |b| {
        b.iter(|| {
            k += 1;
            let body =
                json!({"index": k % 100, "dst": [100.0 + f64::from(k % 7), 90.0]}).to_string();
            let r = handle(&mut doc, "POST", "/api/landmarks/move", body.as_bytes());
            assert_eq!(r.status, 200);
            black_box(r.body.len())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
