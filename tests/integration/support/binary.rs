//! Helpers for tests that run the `photon` binary or read and write files: the command, the
//! committed scenes, a fresh temporary directory per test, and a success check that shows the
//! binary's stderr. `tests/image_hashes.rs` includes this file too.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `photon` binary built for this test run.
pub fn photon() -> Command {
    Command::new(env!("CARGO_BIN_EXE_photon"))
}

/// A scene committed under `scenes/`.
pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// An empty directory for one test, named after the calling test's file, `name` and the process.
#[track_caller]
pub fn temp_dir(name: &str) -> PathBuf {
    let file = Path::new(std::panic::Location::caller().file());
    let topic = file.file_stem().expect("a source file").to_string_lossy();
    let dir = std::env::temp_dir().join(format!("photon-{topic}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Panic with the binary's stderr unless it exited with success.
pub fn assert_success(output: &Output) {
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// `photon render FILE` at 8 × 8 pixels and one sample, the image written into `dir`: for tests
/// of what a file does to the process (its exit code, its messages).
pub fn render_tiny(file: &Path, dir: &Path) -> Output {
    photon()
        .args(["render", file.to_str().unwrap(), "-o"])
        .arg(dir.join("x.exr"))
        .args(["--width", "8", "--height", "8", "--spp", "1"])
        .output()
        .unwrap()
}

/// Standard base64 with padding (for data URIs in test glTF files).
pub fn base64(bytes: &[u8]) -> String {
    const B64: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for (i, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            out.push(if i <= chunk.len() {
                B64[(n >> shift & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}
