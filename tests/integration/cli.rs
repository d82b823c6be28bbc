//! The `photon` binary as users and the Blender add-on run it: exit codes, clear errors, output
//! written atomically, and cancellation by signal leaving nothing behind.

use crate::support::binary;
use binary::*;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn renders_the_embedded_scene_to_exr_and_png() {
    let dir = temp_dir("embedded");
    for name in ["out.exr", "out.png"] {
        let out = dir.join(name);
        let result = photon()
            .args(["render", "-o"])
            .arg(&out)
            .args(["--width", "32", "--height", "24", "--spp", "2"])
            .output()
            .unwrap();
        assert_success(&result);
        assert!(String::from_utf8_lossy(&result.stderr).contains("wrote"));
    }
    let (w, h, pixels) = photon::image_io::read_exr_rgba(&dir.join("out.exr")).unwrap();
    assert_eq!((w, h), (32, 24));
    let mean: f32 = pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / pixels.len() as f32;
    assert!(
        mean > 0.01 && mean.is_finite(),
        "Cornell box rendered black: {mean}"
    );
    assert_eq!(files_in(&dir), ["out.exr", "out.png"]);
}

#[test]
fn json_progress_is_one_object_per_line() {
    let dir = temp_dir("json");
    let result = photon()
        .args([
            "render",
            "--progress",
            "json",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "1",
            "-o",
        ])
        .arg(dir.join("x.exr"))
        .output()
        .unwrap();
    assert_success(&result);
    let stderr = String::from_utf8_lossy(&result.stderr);
    let lines: Vec<serde_json::Value> = stderr
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect();
    assert!(lines.iter().any(|v| v["stage"] == "render"));
    let last = lines.last().unwrap();
    assert_eq!(last["stage"], "done");
    assert!(last["stats"]["rays"].as_u64().unwrap() > 0);
    // No --method: auto, whose pilot finds the Cornell box mostly indirectly lit but the budget
    // (16 × 16 at 1 spp) too small to pay for photon maps: the path tracer, with the choice and
    // its reason reported; the pilot's BVH is the render's, so one build is reported.
    assert_eq!(last["stats"]["method"], "Path", "{last}");
    let plan = lines
        .iter()
        .find(|v| v["stage"] == "plan")
        .expect("the plan");
    let message = plan["message"].as_str().unwrap_or_default();
    assert!(message.starts_with("auto: path tracer ("), "{message}");
    assert!(last["stats"]["build_seconds"].as_f64().unwrap() > 0.0);
    // The whole process's time, and its parts adding up to it.
    let total = last["stats"]["total_seconds"].as_f64().unwrap();
    let parts = last["stats"]["parts_seconds"].as_object().unwrap();
    let sum: f64 = parts.values().map(|t| t.as_f64().unwrap()).sum();
    assert!(total >= last["stats"]["render_seconds"].as_f64().unwrap());
    assert!(
        (sum - total).abs() < 1e-6 * total.max(1.0),
        "{parts:?} vs {total}"
    );
    for part in ["loading", "BVH", "rendering", "writing", "other"] {
        assert!(parts.contains_key(part), "{part} in {parts:?}");
    }
}

#[test]
fn bad_arguments_and_missing_files_exit_with_2() {
    let dir = temp_dir("bad");
    let cases: Vec<Vec<String>> = vec![
        vec!["render".into(), "--width".into(), "0".into()],
        vec!["render".into(), "--spp".into(), "many".into()],
        vec!["render".into(), "--no-such-flag".into()],
        vec![
            "render".into(),
            dir.join("missing.glb").to_string_lossy().into(),
            "-o".into(),
            dir.join("o.exr").to_string_lossy().into(),
        ],
        vec![
            "render".into(),
            "--width".into(),
            "8".into(),
            "--height".into(),
            "8".into(),
            "--spp".into(),
            "1".into(),
            "-o".into(),
            dir.join("o.tiff").to_string_lossy().into(),
        ],
        vec![
            "info".into(),
            dir.join("missing.gltf").to_string_lossy().into(),
        ],
        // Pixel filters Blender does not have, or widths outside its range.
        vec!["render".into(), "--filter".into(), "mitchell".into()],
        vec!["render".into(), "--filter".into(), "gaussian:0".into()],
        vec!["render".into(), "--filter".into(), "box:wide".into()],
        vec!["bench".into(), "--filter".into(), "lanczos".into()],
        // Adaptive sampling's threshold is a number >= 0; its minimum needs a threshold.
        vec!["render".into(), "--adaptive-threshold=-0.1".into()],
        vec!["render".into(), "--adaptive-threshold".into(), "nan".into()],
        vec!["render".into(), "--adaptive-min-samples".into(), "8".into()],
        // The light-path passes need Blender's multilayer naming.
        vec![
            "render".into(),
            "--passes".into(),
            "-o".into(),
            dir.join("o.exr").to_string_lossy().into(),
        ],
    ];
    for args in cases {
        let result = photon().args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(!stderr.trim().is_empty(), "{args:?}: no message");
    }
    assert!(files_in(&dir).is_empty(), "{:?}", files_in(&dir));
}

#[test]
fn sigterm_stops_quickly_with_130_and_keeps_the_old_output() {
    let dir = temp_dir("sigterm");
    let out = dir.join("render.exr");
    std::fs::write(&out, b"previous image").unwrap();
    let mut child = photon()
        .args([
            "render",
            "--progress",
            "json",
            "--width",
            "400",
            "--height",
            "400",
            "--spp",
            "100000",
            "-o",
        ])
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until rendering has started.
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    loop {
        line.clear();
        let n = std::io::BufRead::read_line(&mut stderr, &mut line).unwrap();
        assert!(n > 0, "photon exited before rendering");
        if line.contains("\"build\"") {
            break;
        }
    }
    std::thread::sleep(Duration::from_millis(300));
    let sent = Instant::now();
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let status = child.wait().unwrap();
    let elapsed = sent.elapsed();
    assert_eq!(status.code(), Some(130));
    assert!(elapsed < Duration::from_secs(1), "took {elapsed:?} to stop");
    assert_eq!(std::fs::read(&out).unwrap(), b"previous image");
    assert_eq!(files_in(&dir), ["render.exr"]);
}

#[test]
fn photon_maps_beyond_the_memory_limit_stop_with_a_clear_error() {
    let dir = temp_dir("memory-limit");
    let out = dir.join("out.exr");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass_caustic.glb");
    let run = |limit: &str| {
        photon()
            .arg("render")
            .arg(&scene)
            .args([
                "--method", "photon", "--width", "8", "--height", "8", "--spp", "1",
            ])
            .args(["--photons", "100000", "--memory-limit", limit, "-o"])
            .arg(&out)
            .output()
            .expect("runs")
    };
    // 100 000 photons store about 44 000 photons of 24 bytes: more than 1 MiB with the join copy.
    let refused = run("1");
    assert_eq!(refused.status.code(), Some(2));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("memory limit"), "{err}");
    assert!(
        files_in(&dir).is_empty(),
        "no output when refused: {:?}",
        files_in(&dir)
    );
    let fits = run("64");
    assert!(
        fits.status.success(),
        "{}",
        String::from_utf8_lossy(&fits.stderr)
    );
    assert!(out.exists());
}

#[test]
fn a_width_or_height_alone_keeps_the_scenes_aspect_ratio() {
    // lights.glb stores 320×240: `--width` alone must not pair with the stored height.
    let dir = temp_dir("aspect");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/lights.glb");
    for (flag, value, expected) in [("--width", "32", (32, 24)), ("--height", "12", (16, 12))] {
        let out = dir.join(format!("{value}.exr"));
        let result = photon()
            .args([
                "render", scene, flag, value, "--spp", "1", "--method", "path", "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert_success(&result);
        let (w, h, _) = photon::image_io::read_exr_rgba(&out).unwrap();
        assert_eq!((w, h), expected, "{flag} {value}");
    }
}

/// A one-triangle .gltf with its buffer in a data URI: `positions` (9 bytes as the accessor's
/// `component_type`, or 36 bytes of floats for 5126) and a perspective camera of `yfov`.
fn triangle_gltf(positions: &[u8], component_type: u32, yfov: f32) -> String {
    let data = base64(positions);
    let max = if component_type == 5126 { 1.0 } else { 200.0 };
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
        "nodes": [{{"mesh": 0, "name": "Room"}}, {{"camera": 0, "translation": [0, 0, 5]}}],
        "cameras": [{{"type": "perspective", "perspective": {{"yfov": {yfov}, "znear": 0.1}}}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
        "accessors": [{{"bufferView": 0, "componentType": {component_type}, "count": 3,
            "type": "VEC3", "min": [0, 0, 0], "max": [{max}, {max}, 0]}}],
        "bufferViews": [{{"buffer": 0, "byteLength": {len}}}],
        "buffers": [{{"byteLength": {len},
            "uri": "data:application/octet-stream;base64,{data}"}}]}}"#,
        len = positions.len()
    )
}

#[test]
fn a_zero_field_of_view_and_integer_positions_exit_with_2() {
    let dir = temp_dir("input-checks");
    let floats: Vec<u8> = [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let good = dir.join("good.gltf");
    std::fs::write(&good, triangle_gltf(&floats, 5126, 0.5)).unwrap();
    let cases = [
        ("yfov.gltf", triangle_gltf(&floats, 5126, 0.0), "yfov"),
        (
            "bytes.gltf",
            triangle_gltf(&[0, 0, 0, 200, 0, 0, 0, 200, 0], 5121, 0.5),
            "KHR_mesh_quantization",
        ),
    ];
    let out = dir.join("o.exr");
    let render = |scene: &Path| {
        photon()
            .args([
                "render",
                &scene.to_string_lossy(),
                "-o",
                &out.to_string_lossy(),
            ])
            .args(["--width", "8", "--height", "8", "--spp", "1"])
            .output()
            .unwrap()
    };
    assert_eq!(
        render(&good).status.code(),
        Some(0),
        "the valid file renders"
    );
    std::fs::remove_file(&out).unwrap();
    for (name, text, needle) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let result = render(&path);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{name}: {stderr}");
        assert!(stderr.contains(needle), "{name}: {stderr}");
        assert!(!out.exists(), "{name}: an image was written");
    }
}

#[test]
fn subsurface_chooses_the_walk_or_the_dipole_for_every_translucent_material() {
    // scenes/blender/subsurface.glb: a Random Walk box. `--subsurface dipole` makes it
    // Christensen–Burley: auto then takes the photon method and traces subsurface photons.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/blender/subsurface.glb");
    let dir = temp_dir("subsurface_arg");
    let plan = |choice: &str| {
        let result = photon()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(dir.join(format!("{choice}.exr")))
            .args(["--width", "16", "--height", "16", "--spp", "1"])
            .args(["--subsurface", choice])
            .output()
            .unwrap();
        assert_success(&result);
        String::from_utf8_lossy(&result.stderr).into_owned()
    };
    for choice in ["material", "walk"] {
        let log = plan(choice);
        assert!(log.contains("auto: path tracer"), "{choice}: {log}");
    }
    let log = plan("dipole");
    assert!(log.contains("auto: photon mapping"), "{log}");
    assert!(log.contains("Christensen"), "{log}");
}
