use super::*;

use std::collections::BTreeMap;

const LIMIT: u64 = 1 << 30;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/vdb")
}

fn file(name: &str) -> PathBuf {
    data_dir().join(name)
}

fn grid(name: &str, grid: &str) -> VdbGrid {
    read_grid(&file(name), grid, LIMIT).unwrap_or_else(|e| panic!("{e}"))
}

fn value(g: &VdbGrid, ijk: [i32; 3]) -> &[f32] {
    let local = [0, 1, 2].map(|k| (ijk[k] - g.origin[k]) as usize);
    assert!(
        (0..3).all(|k| local[k] < g.size[k]),
        "{ijk:?} outside {g:?}"
    );
    let at = ((local[2] * g.size[1] + local[1]) * g.size[0] + local[0]) * g.channels;
    &g.values[at..at + g.channels]
}

/// The `file grid bbox …` and `file grid x y z value…` lines of the expected-value files
/// make_vdb.py writes from OpenVDB's own reading of each file.
#[derive(Default)]
struct Expected {
    bbox: Option<[[i32; 3]; 2]>,
    voxels: Vec<([i32; 3], Vec<f32>)>,
}

fn expected() -> BTreeMap<(String, String), Expected> {
    let mut out: BTreeMap<(String, String), Expected> = BTreeMap::new();
    for list in ["expected_py.txt", "expected_cpp.txt"] {
        let text = std::fs::read_to_string(file(list)).unwrap();
        for line in text.lines().filter(|l| !l.is_empty()) {
            let words: Vec<&str> = line.split_whitespace().collect();
            let entry = out.entry((words[0].into(), words[1].into())).or_default();
            if words[2] == "bbox" {
                let n: Vec<i32> = line[line.find("bbox").unwrap() + 4..]
                    .split(|c: char| !(c.is_ascii_digit() || c == '-'))
                    .filter(|w| !w.is_empty())
                    .map(|w| w.parse().unwrap())
                    .collect();
                entry.bbox = Some([[n[0], n[1], n[2]], [n[3], n[4], n[5]]]);
            } else {
                let ijk = [2, 3, 4].map(|i| words[i].parse().unwrap());
                let v = words[5..].iter().map(|w| w.parse().unwrap()).collect();
                entry.voxels.push((ijk, v));
            }
        }
    }
    out
}

#[test]
fn values_and_boxes_match_openvdb_in_every_file() {
    let expected = expected();
    assert!(expected.len() >= 15, "{}", expected.len());
    for ((name, grid_name), e) in &expected {
        let g = grid(name, grid_name);
        let [lo, hi] = e.bbox.unwrap();
        assert_eq!(g.origin, lo, "{name} {grid_name}");
        assert_eq!(
            g.size,
            [0, 1, 2].map(|k| (hi[k] - lo[k] + 1) as usize),
            "{name} {grid_name}"
        );
        assert_eq!(
            g.values.len(),
            g.size.iter().product::<usize>() * g.channels
        );
        assert!(!e.voxels.is_empty());
        for (ijk, v) in &e.voxels {
            assert_eq!(value(&g, *ijk), &v[..], "{name} {grid_name} {ijk:?}");
        }
    }
}

#[test]
fn grid_names_list_float_and_vec3_grids() {
    let names = |f: &str| grid_names(&file(f)).unwrap();
    assert_eq!(names("cube_ramp_8.vdb"), [("density".to_string(), 1)]);
    assert_eq!(names("pyvdb_types.vdb"), [("float".to_string(), 1)]);
    assert_eq!(
        names("cpp_blosc.vdb"),
        [
            ("ramp".into(), 1),
            ("sphere".into(), 1),
            ("velocity".to_string(), 3)
        ]
    );
    assert_eq!(
        names("pyvdb_maps.vdb"),
        [
            ("affine".into(), 1),
            ("translated".into(), 1),
            ("instance".to_string(), 1)
        ]
    );
}

/// Blender's Volume Cube evaluates its Density field for voxel i at index_to_local(i + ½):
/// Blender's voxels are cells whose corners, not centres, sit at integer index coordinates.
#[test]
fn volume_cube_voxels_hold_the_field_at_their_cell_centres() {
    let g = grid("cube_ramp_20x12x9.vdb", "density");
    assert_eq!((g.origin, g.size), ([0; 3], [20, 12, 9]));
    let mut worst = 0.0f32;
    for z in 0..9 {
        for y in 0..12 {
            for x in 0..20 {
                let index = glam::Vec3::new(x as f32, y as f32, z as f32) + 0.5;
                let p = g.index_to_local.transform_point3(index);
                let field = p.x + 10.0 * p.y + 100.0 * p.z;
                worst = worst.max((value(&g, [x, y, z])[0] - field).abs());
            }
        }
    }
    assert!(worst < 2e-4, "{worst}");
    // Min (−1, −2, 0.5) and Max (3, 1, 2.5) are the first and last cells' centres.
    let first = g.index_to_local.transform_point3(glam::Vec3::splat(0.5));
    let last = g
        .index_to_local
        .transform_point3(glam::Vec3::new(19.5, 11.5, 8.5));
    assert!(
        first.abs_diff_eq(glam::Vec3::new(-1.0, -2.0, 0.5), 1e-5),
        "{first}"
    );
    assert!(
        last.abs_diff_eq(glam::Vec3::new(3.0, 1.0, 2.5), 1e-5),
        "{last}"
    );
}

#[test]
fn transforms_of_every_map_kind() {
    let point = |g: &VdbGrid, p: [f32; 3]| g.index_to_local.transform_point3(glam::Vec3::from(p));
    let close = |a: glam::Vec3, b: [f32; 3]| assert!(a.abs_diff_eq(b.into(), 1e-6), "{a} {b:?}");
    // AffineMap (rotation, non-uniform scale, translation): rows are the images of x, y, z.
    let affine = grid("pyvdb_maps.vdb", "affine");
    close(point(&affine, [0.0, 0.0, 0.0]), [4.0, 5.0, 6.0]);
    close(point(&affine, [1.0, 0.0, 0.0]), [4.0, 7.0, 6.0]);
    close(point(&affine, [0.0, 1.0, 0.0]), [3.0, 5.0, 6.0]);
    close(point(&affine, [0.0, 0.0, 1.0]), [4.0, 5.0, 9.0]);
    // TranslationMap.
    close(
        point(&grid("pyvdb_maps.vdb", "translated"), [1.0, 1.0, 1.0]),
        [0.0, -1.0, -2.0],
    );
    // ScaleTranslateMap and UniformScaleMap.
    close(
        point(&grid("pyvdb_tiles.vdb", "tiles"), [1.0, 1.0, 1.0]),
        [1.5, 2.25, 5.0],
    );
    close(
        point(&grid("pyvdb_tiles.vdb", "velocity"), [1.0, 2.0, 3.0]),
        [0.1, 0.2, 0.3],
    );
    // UniformScaleTranslateMap (Blender's bakes, OpenVDB's post-translated linear transform).
    close(
        point(&grid("cpp_zip.vdb", "ramp"), [4.0, 0.0, 0.0]),
        [2.0, 2.0, 3.0],
    );
    // An instance shares its parent's voxels under its own transform.
    let instance = grid("pyvdb_maps.vdb", "instance");
    assert_eq!(
        (instance.origin, instance.size),
        (affine.origin, affine.size)
    );
    assert_eq!(instance.values, affine.values);
    close(point(&instance, [1.0, 0.0, 0.0]), [2.0, 0.0, 0.0]);
}

#[test]
fn tiles_fill_their_voxels() {
    let g = grid("pyvdb_tiles.vdb", "tiles");
    assert_eq!(g.origin, [-8, 0, 0]);
    assert_eq!(g.size, [264, 128, 128]);
    assert_eq!(value(&g, [-8, 0, 0]), [2.0]); // a whole leaf as a lower node's tile
    assert_eq!(value(&g, [-1, 7, 7]), [2.0]);
    assert_eq!(value(&g, [200, 100, 50]), [3.0]); // an upper node's tile
    assert_eq!(value(&g, [-3, 9, 1]), [-3.0 + 90.0 + 100.0]);
    assert_eq!(value(&g, [5, 5, 20]), [-7.0]); // an inactive voxel with its own value
    assert_eq!(value(&g, [50, 50, 50]), [0.25]); // background
}

#[test]
fn unsupported_grids_and_missing_names_are_clear_errors() {
    let message = |grid: &str| {
        read_grid(&file("pyvdb_types.vdb"), grid, LIMIT)
            .unwrap_err()
            .to_string()
    };
    assert!(
        message("double").contains("grid type Tree_double_5_4_3"),
        "{}",
        message("double")
    );
    assert!(
        message("bool").contains("Tree_bool_5_4_3"),
        "{}",
        message("bool")
    );
    assert!(
        message("int").contains("not supported"),
        "{}",
        message("int")
    );
    assert_eq!(grid("pyvdb_types.vdb", "float").values, [0.5]);
    let missing = message("smoke");
    assert!(
        missing.contains("no grid named 'smoke'") && missing.contains("'float'"),
        "{missing}"
    );
    let not_vdb = read_grid(&file("expected_py.txt"), "density", LIMIT).unwrap_err();
    assert!(matches!(not_vdb, VdbError::NotVdb { .. }), "{not_vdb}");
}

#[test]
fn a_dense_box_over_the_limit_is_refused() {
    // 8³ floats are 2048 bytes.
    assert_eq!(grid("cube_ramp_8.vdb", "density").values.len(), 512);
    assert!(read_grid(&file("cube_ramp_8.vdb"), "density", 2048).is_ok());
    let error = read_grid(&file("cube_ramp_8.vdb"), "density", 2047).unwrap_err();
    assert!(
        matches!(
            error,
            VdbError::TooLarge {
                bytes: 2048,
                max_bytes: 2047,
                ..
            }
        ),
        "{error}"
    );
    // Without bbox metadata, from the topology: 264×128×128 floats.
    let error = read_grid(&file("pyvdb_tiles.vdb"), "tiles", 1 << 20).unwrap_err();
    assert!(error.to_string().contains("264×128×128"), "{error}");
}

/// Every file read as if written without grid offsets: each grid is found by parsing past
/// the ones before it, and reads the same.
#[test]
fn files_read_the_same_without_grid_offsets() {
    for name in vdb_files() {
        let data = std::fs::read(file(&name)).unwrap();
        let mut streamed = data.clone();
        streamed[20] = 0; // has_grid_offsets
        let path = file(&name);
        let names = grid_names_in(&data, &path).unwrap();
        assert_eq!(grid_names_in(&streamed, &path).unwrap(), names, "{name}");
        for (grid, _) in &names {
            let a = read_grid_in(&data, &path, grid, LIMIT).unwrap();
            let b = read_grid_in(&streamed, &path, grid, LIMIT).unwrap();
            assert_eq!((a.origin, a.size), (b.origin, b.size));
            assert!(a.values == b.values, "{name} {grid}");
        }
    }
}

fn vdb_files() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(data_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".vdb"))
        .collect();
    names.sort();
    names
}

/// Truncated files are errors; files with a damaged byte are read or refused, never panic.
#[test]
fn truncated_and_damaged_files_never_panic() {
    for name in [
        "cube_ramp_8.vdb",
        "cpp_zip_half.vdb",
        "cpp_none.vdb",
        "pyvdb_maps.vdb",
    ] {
        let path = file(name);
        let data = std::fs::read(&path).unwrap();
        let names = grid_names_in(&data, &path).unwrap();
        let last = &names.last().unwrap().0;
        for end in (0..data.len()).step_by(97) {
            let cut = &data[..end];
            assert!(grid_names_in(cut, &path).is_err(), "{name} cut at {end}");
            assert!(
                read_grid_in(cut, &path, last, LIMIT).is_err(),
                "{name} cut at {end}"
            );
        }
        for at in (0..data.len()).step_by(29) {
            for flip in [0xff, 0x01] {
                let mut bad = data.clone();
                bad[at] ^= flip;
                let _ = grid_names_in(&bad, &path);
                for (grid, _) in &names {
                    let _ = read_grid_in(&bad, &path, grid, 64 << 20);
                }
            }
        }
    }
}

/// Read time and peak memory of a large grid: `PHOTON_VDB_BENCH=file.vdb cargo test --release
/// --lib vdb::tests::read_time -- --ignored --nocapture` (make one with make_vdb.py --large).
#[test]
#[ignore]
fn read_time() {
    let path = PathBuf::from(std::env::var("PHOTON_VDB_BENCH").expect("PHOTON_VDB_BENCH"));
    let peak_kib = || {
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        status
            .lines()
            .find_map(|l| l.strip_prefix("VmHWM:"))
            .and_then(|v| v.trim().trim_end_matches(" kB").trim().parse::<u64>().ok())
            .unwrap_or(0)
    };
    let before = peak_kib();
    let start = std::time::Instant::now();
    let names = grid_names(&path).unwrap();
    let names_time = start.elapsed();
    for (name, _) in &names {
        let start = std::time::Instant::now();
        let g = read_grid(&path, name, u64::MAX).unwrap();
        let time = start.elapsed();
        println!(
            "{name}: {:?} voxels, {} MiB dense, read in {:.3} s; grid_names {:.3} s; peak RSS {} MiB (before {} MiB)",
            g.size,
            (g.values.len() * 4) >> 20,
            time.as_secs_f64(),
            names_time.as_secs_f64(),
            peak_kib() >> 10,
            before >> 10
        );
    }
}
