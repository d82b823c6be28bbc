//! Refactoring guard: every shipped scene rendered by every method at a tiny size, on one and on
//! two threads, must give exactly the image recorded in `tests/data/image_hashes.txt` (a hash of
//! the EXR with every pass). A change meant to move no pixel is checked bit for bit this way; a
//! change meant to move pixels re-records the file (`PHOTON_RECORD_HASHES=1 cargo test --release
//! --test image_hashes`) and says in its commit which images changed and by how much.
//! A crate of its own rather than a module of `integration/`: it runs the `photon` binary and
//! never links the library, and this command is the one every change is checked with.

// The integration tests' helpers for running the binary (this crate uses only some of them).
#[path = "integration/support/binary.rs"]
#[allow(dead_code)]
mod binary;

use binary::{assert_success, photon, temp_dir};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The methods, each as the arguments that select it.
const METHODS: &[(&str, &[&str])] = &[
    ("auto", &["--method", "auto"]),
    ("path", &["--method", "path"]),
    (
        "photon",
        &["--method", "photon", "--irradiance-cache", "off"],
    ),
    (
        "photon-ic",
        &["--method", "photon", "--irradiance-cache", "on"],
    ),
    ("photon-global", &["--method", "photon-global"]),
    ("photon-caustic", &["--method", "photon-caustic"]),
    ("photons", &["--method", "photons"]),
    ("path-cache", &["--method", "path-cache"]),
    ("ic-irradiance", &["--method", "ic-irradiance"]),
    ("ic-records", &["--method", "ic-records"]),
];

/// Small budgets: the point is to run every branch of every integrator, not to converge.
const BUDGET: &[&str] = &[
    "--width",
    "12",
    "--height",
    "12",
    "--spp",
    "2",
    "--photons",
    "3000",
    "--caustic-photons",
    "2000",
    "--subsurface-photons",
    "3000",
    "--ic-gather-rays",
    "16",
    "--progress",
    "none",
    "--exr-layer",
    "ViewLayer",
    "--passes",
];

fn record_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/image_hashes.txt")
}

/// Every `.glb` under `scenes/`, `scenes/gallery/` and `scenes/blender/`, by relative path.
fn shipped_scenes() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut scenes = Vec::new();
    for dir in ["", "gallery", "blender"] {
        let entries = std::fs::read_dir(root.join(dir)).expect("scenes folder");
        for entry in entries {
            let name = entry.expect("dir entry").file_name();
            let name = name.to_string_lossy();
            if name.ends_with(".glb") {
                scenes.push(if dir.is_empty() {
                    name.to_string()
                } else {
                    format!("{dir}/{name}")
                });
            }
        }
    }
    scenes.sort();
    scenes
}

/// FNV-1a, 64 bits: stable across Rust versions, unlike `DefaultHasher`.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

fn render_hash(scene: &str, method: &[&str], threads: u32, out: &Path) -> u64 {
    let output = photon()
        .arg("render")
        .arg(binary::scene_path(scene))
        .args(method)
        .args(BUDGET)
        .args(["--threads", &threads.to_string(), "-o"])
        .arg(out)
        .output()
        .expect("run photon");
    assert_success(&output);
    fnv1a(&std::fs::read(out).expect("read image"))
}

#[test]
fn every_scene_and_method_renders_the_recorded_image_on_one_and_two_threads() {
    let dir = temp_dir("hashes");
    let mut hashes = BTreeMap::new();
    for scene in shipped_scenes() {
        for (name, args) in METHODS {
            let one = render_hash(&scene, args, 1, &dir.join("one.exr"));
            let two = render_hash(&scene, args, 2, &dir.join("two.exr"));
            assert_eq!(one, two, "{scene} {name}: 1 and 2 threads differ");
            hashes.insert(format!("{scene} {name}"), format!("{one:016x}"));
        }
    }
    let text: String = hashes
        .iter()
        .map(|(key, hash)| format!("{key} {hash}\n"))
        .collect();
    if std::env::var_os("PHOTON_RECORD_HASHES").is_some() {
        std::fs::create_dir_all(record_file().parent().expect("parent")).expect("mkdir");
        std::fs::write(record_file(), &text).expect("write hashes");
        return;
    }
    let recorded = std::fs::read_to_string(record_file()).expect("tests/data/image_hashes.txt");
    let recorded: BTreeMap<&str, &str> = recorded
        .lines()
        .filter_map(|l| l.rsplit_once(' '))
        .collect();
    let changed: Vec<String> = hashes
        .iter()
        .filter(|(key, hash)| recorded.get(key.as_str()) != Some(&hash.as_str()))
        .map(|(key, _)| key.clone())
        .collect();
    assert!(
        changed.is_empty() && recorded.len() == hashes.len(),
        "{} of {} images differ from the record ({} recorded): {changed:?}",
        changed.len(),
        hashes.len(),
        recorded.len()
    );
}
