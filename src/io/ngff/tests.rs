use super::*;
use serde_json::json;
use zarrs::array::{data_type, ArrayBuilder};
use zarrs::group::GroupBuilder;

/// A Zarr v3 OME-Zarr 0.5 image with the given axes and data type, two levels.
fn make_v3(dir: &Path, axes: serde_json::Value, shape: Vec<u64>, dt: zarrs::array::DataType) {
    let store = Arc::new(FilesystemStore::new(dir).unwrap());
    let attrs = json!({"ome": {"version": "0.5", "multiscales": [{
        "axes": axes,
        "datasets": [
            {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": vec![1.0; shape.len()]}]},
            {"path": "1", "coordinateTransformations": [{"type": "scale", "scale": vec![2.0; shape.len()]}]}
        ]
    }]}});
    GroupBuilder::new()
        .attributes(attrs.as_object().unwrap().clone())
        .build(store.clone(), "/")
        .unwrap()
        .store_metadata()
        .unwrap();
    let chunks: Vec<u64> = shape.iter().map(|&s| s.min(4)).collect();
    let n: u64 = shape.iter().product();
    if dt == data_type::uint16() {
        let a = ArrayBuilder::new(shape, chunks, dt, 0u16).build(store, "/0").unwrap();
        a.store_metadata().unwrap();
        let d: Vec<u16> = (0..n).map(|i| (i * 37 % 65536) as u16).collect();
        a.store_array_subset(&a.subset_all(), &d[..]).unwrap();
    } else {
        let a = ArrayBuilder::new(shape, chunks, dt, 0i32).build(store, "/0").unwrap();
        a.store_metadata().unwrap();
    }
}

#[test]
fn a_v3_tcyx_image_round_trips_level_0() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("img.zarr");
    std::fs::create_dir(&p).unwrap();
    let axes = json!([
        {"name": "t", "type": "time"}, {"name": "c", "type": "channel"},
        {"name": "y", "type": "space", "unit": "micrometer"}, {"name": "x", "type": "space"}
    ]);
    make_v3(&p, axes, vec![2, 3, 5, 7], data_type::uint16());
    let img = read_image(&p).unwrap();
    assert_eq!(img.zarr_format, 3);
    assert_eq!(img.shape, vec![2, 3, 5, 7]);
    assert_eq!(img.chunks, vec![2, 3, 4, 4]);
    assert_eq!(img.dtype, SampleType::U16);
    assert_eq!(img.pages.len(), 6);
    assert_eq!((img.width(), img.height()), (7, 5));
    assert_eq!(img.axes[2].unit.as_deref(), Some("micrometer"));
    // Plane k, pixel (x, y) is element k * 35 + y * 7 + x.
    let DynamicImage::ImageLuma16(b) = &img.pages[4] else { panic!("16-bit gray") };
    assert_eq!(b.get_pixel(3, 2).0[0], ((4 * 35 + 2 * 7 + 3) * 37) as u16);
    let out = dir.path().join("out.zarr");
    write_image(&out, &img, &img.pages).unwrap();
    let back = read_image(&out).unwrap();
    assert_eq!(back.shape, img.shape);
    assert_eq!(back.chunks, img.chunks);
    for (a, b) in back.pages.iter().zip(&img.pages) {
        assert_eq!(a.as_bytes(), b.as_bytes());
    }
    let g: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("zarr.json")).unwrap()).unwrap();
    let ds = &g["attributes"]["ome"]["multiscales"][0]["datasets"];
    assert_eq!(ds.as_array().unwrap().len(), 1, "only level 0 is written: {ds}");
    assert_eq!(g["attributes"]["ome"]["version"], "0.5");
    // Writing again replaces the store in place (atomically), leaving no temporary.
    write_image(&out, &img, &img.pages).unwrap();
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn unsupported_axes_and_types_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("z.zarr");
    std::fs::create_dir(&p).unwrap();
    let axes = json!([
        {"name": "z", "type": "space"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}
    ]);
    make_v3(&p, axes, vec![2, 4, 4], data_type::uint16());
    let e = read_image(&p).unwrap_err().to_string();
    assert!(e.contains("z.zarr") && e.contains("z, y, x") && e.contains("3 spatial axes"), "{e}");

    let q = dir.path().join("i32.zarr");
    std::fs::create_dir(&q).unwrap();
    let axes = json!([{"name": "y", "type": "space"}, {"name": "x", "type": "space"}]);
    make_v3(&q, axes, vec![4, 4], data_type::int32());
    let e = read_image(&q).unwrap_err().to_string();
    assert!(e.contains("i32.zarr") && e.contains("array `0`") && e.contains("int32"), "{e}");

    // No array metadata under the dataset path.
    std::fs::remove_file(q.join("0").join("zarr.json")).unwrap();
    let e = read_image(&q).unwrap_err().to_string();
    assert!(e.contains("array `0`") && e.contains("zarr.json"), "{e}");

    // Not a store at all.
    let e = read_image(&dir.path().join("missing.zarr")).unwrap_err().to_string();
    assert!(e.contains("missing.zarr") && e.contains("no such directory"), "{e}");
    let empty = dir.path().join("empty.zarr");
    std::fs::create_dir(&empty).unwrap();
    let e = read_image(&empty).unwrap_err().to_string();
    assert!(e.contains("no group metadata"), "{e}");
}

#[test]
fn a_directory_that_is_not_a_store_is_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("precious");
    std::fs::create_dir(&p).unwrap();
    std::fs::write(p.join("notes.txt"), b"keep me").unwrap();
    let e = write_store_atomic(&p, |_| Ok(())).unwrap_err().to_string();
    assert!(e.contains("not a Zarr store"), "{e}");
    assert_eq!(std::fs::read(p.join("notes.txt")).unwrap(), b"keep me");
    // A failing writer leaves nothing behind.
    let t = dir.path().join("t.zarr");
    let r = write_store_atomic(&t, |tmp| {
        std::fs::write(tmp.join("zarr.json"), b"{}").unwrap();
        Err(NgffError::Write { store: t.clone(), reason: "boom".into() })
    });
    assert!(r.is_err());
    assert!(!t.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only `precious` is left");
}

/// Bug (issue 55): the warp of a uint8 Zarr v3 image wrote its `bytes` codec (which has no
/// byte order for one-byte samples) as the bare string `"bytes"`, and zarr-python 3.1
/// could not open the result. Every codec is now an object; `dimension_names` are kept.
#[test]
fn a_uint8_v3_image_is_written_with_codec_objects_and_its_dimension_names() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("u8.zarr");
    std::fs::create_dir(&p).unwrap();
    let store = Arc::new(FilesystemStore::new(&p).unwrap());
    let attrs = json!({"ome": {"version": "0.5", "multiscales": [{
        "axes": [{"name": "t", "type": "time"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0, 1.0, 1.0]}]}]
    }]}});
    GroupBuilder::new()
        .attributes(attrs.as_object().unwrap().clone())
        .build(store.clone(), "/")
        .unwrap()
        .store_metadata()
        .unwrap();
    let a = ArrayBuilder::new(vec![2, 5, 7], vec![1, 4, 4], data_type::uint8(), 0u8)
        .dimension_names(Some(["t", "y", "x"]))
        .build(store, "/0")
        .unwrap();
    a.store_metadata().unwrap();
    let d: Vec<u8> = (0..70u32).map(|i| (i * 37 % 256) as u8).collect();
    a.store_array_subset(&a.subset_all(), &d[..]).unwrap();

    let img = read_image(&p).unwrap();
    assert_eq!(img.dtype, SampleType::U8);
    let out = dir.path().join("out.zarr");
    write_image(&out, &img, &img.pages).unwrap();
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("0").join("zarr.json")).unwrap()).unwrap();
    let codecs = meta["codecs"].as_array().unwrap();
    assert!(!codecs.is_empty());
    for c in codecs {
        assert!(c.is_object() && c["name"].is_string(), "codec {c} in {meta}");
    }
    assert!(codecs.iter().any(|c| c["name"] == "bytes"), "{meta}");
    assert!(meta["chunk_grid"].is_object() && meta["chunk_key_encoding"].is_object(), "{meta}");
    assert_eq!(meta["data_type"], "uint8");
    assert_eq!(meta["dimension_names"], json!(["t", "y", "x"]));
    let back = read_image(&out).unwrap();
    for (a, b) in back.pages.iter().zip(&img.pages) {
        assert_eq!(a.as_bytes(), b.as_bytes());
    }
}

/// Codecs nested in a sharding codec's configuration get the object form too.
#[test]
fn nested_codec_names_become_objects() {
    use zarrs::metadata::v3::MetadataV3;
    let dir = tempfile::tempdir().unwrap();
    let store = Arc::new(FilesystemStore::new(dir.path()).unwrap());
    let a = ArrayBuilder::new(vec![4, 4], vec![4, 4], data_type::uint8(), 0u8)
        .build(store, "/a")
        .unwrap();
    let zarrs::metadata::ArrayMetadata::V3(mut v3) = a.metadata().clone() else {
        panic!("a v3 array")
    };
    let conf = json!({"chunk_shape": [2, 2], "codecs": ["bytes"], "index_codecs": ["bytes", {"name": "crc32c"}]});
    v3.codecs = vec![MetadataV3::new_with_configuration(
        "sharding_indexed",
        conf.as_object().unwrap().clone(),
    )];
    let mut meta = zarrs::metadata::ArrayMetadata::V3(v3);
    codecs_as_objects(&mut meta);
    let v = serde_json::to_value(&meta).unwrap();
    let c = &v["codecs"][0]["configuration"];
    assert_eq!(c["codecs"], json!([{"name": "bytes"}]), "{v}");
    assert_eq!(c["index_codecs"], json!([{"name": "bytes"}, {"name": "crc32c"}]), "{v}");
}
