//! `photon bench` renders every method at every budget against a cached two-half reference and
//! writes the CSV, the report (time to a target error, auto against the fixed methods) and
//! summary.json.

use std::path::{Path, PathBuf};
use std::process::Command;

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

fn photon() -> Command {
    Command::new(env!("CARGO_BIN_EXE_photon"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("photon-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

#[test]
fn bench_writes_results_for_each_method_and_budget() {
    let dir = temp_dir("all");
    let result = photon()
        .arg("bench")
        .arg(scene_path("cornell_box.glb"))
        .args(["--budgets", "1,2", "--width", "16", "--height", "16"])
        .args(["--reference-spp", "16", "--threads", "2", "--out"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
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
    assert!(dir.join("report.md").exists());
    assert!(dir.join("cornell_box.svg").exists());
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
}
