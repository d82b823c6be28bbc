//! `photon bench` renders every method at every budget against a cached two-half reference and
//! writes the CSV, the report (time to a target error, auto against the fixed methods) and
//! summary.json.

use crate::support::binary;
use binary::*;

#[test]
fn bench_writes_results_for_each_method_and_budget() {
    let dir = temp_dir("all");
    let result = photon()
        .arg("bench")
        .arg(scene_path("cornell_box.glb"))
        .args(["--budgets", "1,2", "--width", "16", "--height", "16"])
        .args([
            "--reference-spp",
            "16",
            "--threads",
            "2",
            "--repeats",
            "2",
            "--out",
        ])
        .arg(&dir)
        .output()
        .expect("runs");
    assert_success(&result);
    // Repeats go round all the renders: two rounds, one row per render.
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(stderr.contains("round 2 of 2"), "{stderr}");
    let csv = std::fs::read_to_string(dir.join("results.csv")).expect("results.csv");
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 8, "{csv}");
    for method in ["path", "photon", "photon-ic", "auto"] {
        for budget in ["1", "2"] {
            let prefix = format!("cornell_box,{method},{budget},");
            assert!(
                rows.iter().any(|r| r.starts_with(&prefix)),
                "{prefix}: {csv}"
            );
        }
    }
    assert!(dir.join("cornell_box.svg").exists());
    // The reference: the mean of two halves (the halves themselves are removed) and its noise.
    let mut refs: Vec<String> = std::fs::read_dir(dir.join("refs"))
        .expect("refs")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    refs.sort();
    assert_eq!(refs.len(), 2, "{refs:?}");
    assert!(refs[0].ends_with("-16spp-path.exr") && refs[1].ends_with("-16spp-path.noise.json"));
    let cached: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("refs").join(&refs[1])).expect("noise file"),
    )
    .expect("noise JSON");
    let noise = cached["reference_noise_rel_mse"].as_f64().expect("noise");
    assert!(noise > 0.0 && noise.is_finite(), "{noise}");
    let report = std::fs::read_to_string(dir.join("report.md")).expect("report.md");
    assert!(
        report.contains("Reference: the path tracer; noise ≈ relMSE"),
        "{report}"
    );
    let (_, time_table) = report
        .split_once("### Time to relMSE 0.01")
        .expect("time-to-target table");
    for method in ["path", "photon", "photon-ic", "auto"] {
        let row = format!("\n| {method} | ");
        assert!(time_table.contains(&row), "{row}: {report}");
    }
    let (_, auto_table) = report
        .split_once("### Auto against the best fixed method")
        .expect("auto table");
    assert_eq!(
        auto_table.matches("\n| 1 | ").count() + auto_table.matches("\n| 2 | ").count(),
        2,
        "{report}"
    );
    assert!(
        auto_table.contains("Auto within tolerance at ") && auto_table.contains(" of 2 budgets."),
        "{report}"
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("summary.json")).expect("summary.json"),
    )
    .expect("summary JSON");
    assert_eq!(summary["target_rel_mse"], 0.01);
    let scene = &summary["scenes"][0];
    assert_eq!(scene["scene"], "cornell_box");
    assert_eq!(scene["reference_noise_rel_mse"].as_f64(), Some(noise));
    for method in ["path", "photon", "photon-ic", "auto"] {
        let status = scene["time_to_target"][method]["status"].as_str();
        assert!(
            matches!(status, Some("reached" | "at_most" | "not_reached")),
            "{method}: {summary}"
        );
    }
    let checks = scene["auto_check"].as_array().expect("auto checks");
    assert_eq!(checks.len(), 2, "{summary}");
    for check in checks {
        let ratio = check["auto_rel_mse"].as_f64().expect("auto")
            / check["best_fixed_rel_mse"].as_f64().expect("best");
        assert!((check["ratio"].as_f64().expect("ratio") - ratio).abs() <= 1e-9 * ratio);
        assert_eq!(check["ok"].as_bool(), Some(ratio <= 1.25));
    }
    // Each method's longest budget split into noise and bias.
    let (_, bias_table) = report
        .split_once("### Bias at the longest budget")
        .expect("bias table");
    let biases = scene["bias_at_longest_budget"].as_array().expect("biases");
    assert_eq!(biases.len(), 4, "{summary}");
    for b in biases {
        let method = b["method"].as_str().expect("method");
        assert_eq!(b["budget"], 2, "{summary}");
        assert!(
            bias_table.contains(&format!("\n| {method} | 2 | ")),
            "{report}"
        );
        let (noise, bias) = (b["noise_rel_mse"].as_f64(), b["bias_rel_mse"].as_f64());
        assert!(noise.is_some_and(|n| n > 0.0) && bias.is_some_and(|b| b >= 0.0));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unknown_bench_method_is_a_settings_error_naming_the_valid_ones() {
    let dir = temp_dir("unknown");
    let result = photon()
        .arg("bench")
        .arg(scene_path("cornell_box.glb"))
        .args(["--methods", "path,photon-cache", "--out"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert_eq!(result.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(stderr.contains("photon-cache"), "{stderr}");
    assert!(stderr.contains("path, photon, photon-ic, auto"), "{stderr}");
    assert!(
        !dir.join("refs").exists(),
        "nothing renders on a bad method"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_photon_reference_converges_to_the_path_reference_where_both_converge() {
    // The caustic-free furnace: the photon-method reference (consistent, so it converges) and
    // the path-traced one must agree, and their files are kept apart by the method in the key.
    let mean = |method: &str| -> f64 {
        let dir = temp_dir(&format!("reference-{method}"));
        let result = photon()
            .arg("bench")
            .arg(scene_path("furnace.glb"))
            .args([
                "--budgets",
                "1",
                "--methods",
                "path",
                "--width",
                "16",
                "--height",
                "16",
            ])
            .args([
                "--reference-spp",
                "64",
                "--reference-method",
                method,
                "--out",
            ])
            .arg(&dir)
            .output()
            .expect("runs");
        assert_success(&result);
        let refs: Vec<String> = std::fs::read_dir(dir.join("refs"))
            .expect("refs")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        let exr = refs
            .iter()
            .find(|r| r.ends_with(".exr"))
            .expect("reference EXR");
        assert!(exr.ends_with(&format!("-64spp-{method}.exr")), "{refs:?}");
        let csv = std::fs::read_to_string(dir.join("results.csv")).expect("csv");
        // The path render's mean relative difference tells the reference's mean apart.
        let row = csv.lines().nth(1).expect("a row");
        row.rsplit(',')
            .next()
            .expect("last column")
            .parse()
            .expect("number")
    };
    let (path, photon_ref) = (mean("path"), mean("photon"));
    assert!(
        (path - photon_ref).abs() < 0.01,
        "path render against a path reference {path:+.4}, against a photon reference {photon_ref:+.4}"
    );
}
