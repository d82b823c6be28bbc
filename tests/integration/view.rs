//! `photon view`, the interactive mode behind the Blender add-on's Rendered viewport: a request
//! on stdin renders its view into the image file; a newer request cancels the one running and
//! the images that follow show the new view; malformed requests get error events and change
//! nothing; the end of stdin ends the process; photon mapping shows a path-traced sample while
//! its maps are built; render-only flags and unreadable scenes exit with 2. Scene: the embedded
//! Cornell box (red wall on the left, green on the right, seen from its camera at
//! (0, 2.775, 10.775) looking along −Z).

use crate::support::binary::{photon, temp_dir};
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// The Cornell box camera's pose, row-major; `rolled` turns it half a turn about its view axis
/// (the red wall then on the right).
fn pose(rolled: bool) -> Vec<f32> {
    let s = if rolled { -1.0 } else { 1.0 };
    vec![
        s, 0.0, 0.0, 0.0, 0.0, s, 0.0, 2.775, 0.0, 0.0, 1.0, 10.775, 0.0, 0.0, 0.0, 1.0,
    ]
}

fn request(id: u64, size: u32, rolled: bool) -> String {
    json!({"id": id, "width": size, "height": size, "camera_to_world": pose(rolled),
           "projection": "perspective", "yfov": 39.3f32.to_radians()})
    .to_string()
}

struct Viewer {
    /// The test's folder and the image file in it.
    dir: PathBuf,
    image: PathBuf,
    child: Child,
    stdin: Option<ChildStdin>,
    events: Receiver<Value>,
    /// Every event received so far.
    log: Vec<Value>,
}

impl Viewer {
    /// `photon view` of the embedded Cornell box by the path tracer at `spp` samples, its image
    /// in a fresh folder.
    #[track_caller]
    fn start(name: &str, spp: u32) -> Viewer {
        Viewer::start_with(name, &["--method", "path", "--spp", &spp.to_string()])
    }

    /// `photon view` of the embedded Cornell box with `flags`, its image in a fresh folder.
    #[track_caller]
    fn start_with(name: &str, flags: &[&str]) -> Viewer {
        let dir = temp_dir(name);
        let image = dir.join("view.raw");
        let mut child = photon()
            .args(["view", "-o"])
            .arg(&image)
            .args(flags)
            .args(["--progress", "json"])
            .stdin(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let stderr = child.stderr.take().unwrap();
        let (send, events) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(|l| l.ok()) {
                if let Ok(value) = serde_json::from_str::<Value>(&line) {
                    let _ = send.send(value);
                }
            }
        });
        let stdin = child.stdin.take();
        Viewer {
            dir,
            image,
            child,
            stdin,
            events,
            log: Vec::new(),
        }
    }

    fn send(&mut self, line: &str) {
        self.send_bytes(line.as_bytes());
    }

    fn send_bytes(&mut self, line: &[u8]) {
        let stdin = self.stdin.as_mut().unwrap();
        stdin.write_all(line).unwrap();
        stdin.write_all(b"\n").unwrap();
        stdin.flush().unwrap();
    }

    /// The first event for which `wanted` holds, within `seconds`; the others are dropped.
    fn wait(&mut self, seconds: f64, wanted: impl Fn(&Value) -> bool) -> Value {
        let end = Instant::now() + Duration::from_secs_f64(seconds);
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(event) => {
                    self.log.push(event.clone());
                    if wanted(&event) {
                        return event;
                    }
                }
                Err(e) => panic!("no such event within {seconds} s: {e}"),
            }
        }
    }

    /// Close stdin: the process must end with success; the seconds it took to end.
    fn finish(mut self) -> f64 {
        let closed = Instant::now();
        drop(self.stdin.take());
        let status = self.child.wait().unwrap();
        assert!(status.success(), "{status}");
        let seconds = closed.elapsed().as_secs_f64();
        let _ = std::fs::remove_dir_all(&self.dir);
        seconds
    }

    fn image_of(&mut self, id: u64, last: bool, seconds: f64) -> Value {
        self.wait(seconds, |e| {
            e["stage"] == "image" && e["request"] == id && (!last || e["final"] == true)
        })
    }
}

/// The image file: (width, height, spp, request, mean red minus green of the left and right
/// halves).
fn read_image(path: &Path) -> (u32, u32, u32, u64, f32, f32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..4], b"PHVW");
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
    let (w, h, spp) = (u32_at(4), u32_at(8), u32_at(12));
    let request = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    assert_eq!(bytes.len(), 24 + (w * h * 16) as usize);
    let value = |x: u32, y: u32, c: u32| {
        let i = 24 + (((y * w + x) * 4 + c) * 4) as usize;
        f32::from_le_bytes(bytes[i..i + 4].try_into().unwrap())
    };
    let half = |xs: std::ops::Range<u32>| {
        let mut sum = 0.0;
        for y in 0..h {
            for x in xs.clone() {
                sum += value(x, y, 0) - value(x, y, 1);
            }
        }
        sum / (xs.len() as u32 * h) as f32
    };
    (w, h, spp, request, half(0..w / 2), half(w / 2..w))
}

#[test]
fn view_a_new_request_cancels_the_running_one_and_shows_the_new_view() {
    let mut viewer = Viewer::start("cancel", 256);
    viewer.wait(30.0, |e| e["stage"] == "ready");
    // A long render of the upright view: its first (quarter-size) image, then a rolled view.
    viewer.send(&request(1, 256, false));
    let first = viewer.image_of(1, false, 30.0);
    assert_eq!(
        first["width"], 64,
        "the first image is a quarter of the size: {first}"
    );
    let (_, _, _, id, left, right) = read_image(&viewer.image);
    if id == 1 {
        assert!(left > right, "upright: red on the left ({left} vs {right})");
    }
    let sent = Instant::now();
    viewer.send(&request(2, 256, true));
    let second = viewer.image_of(2, false, 30.0);
    let latency = sent.elapsed().as_secs_f64();
    // The running render stops within its cancel checks' few milliseconds; the bounds leave
    // room for a loaded machine.
    assert!(latency < 2.0, "the new view's first image took {latency} s");
    let stopped = viewer
        .log
        .iter()
        .find(|e| e["stage"] == "cancelled" && e["request"] == 1)
        .cloned()
        .expect("request 1 was cancelled");
    assert_eq!(stopped["by"], 2);
    let seconds = stopped["seconds"].as_f64().unwrap();
    assert!(seconds < 0.5, "request 1 took {seconds} s to stop");
    println!("view: request 1 stopped {seconds:.4} s after request 2 was read");
    assert!(second["seconds"].as_f64().unwrap() < 2.0, "{second}");
    // The rolled view, small, to its last image.
    viewer.send(&request(3, 16, true));
    viewer.image_of(3, true, 60.0);
    let (w, h, spp, id, left, right) = read_image(&viewer.image);
    assert_eq!((w, h, spp, id), (16, 16, 256, 3));
    assert!(
        right > left + 0.05,
        "rolled: red on the right ({left} vs {right})"
    );
    viewer.send(&request(4, 16, false));
    viewer.image_of(4, true, 60.0);
    let (_, _, _, id, left, right) = read_image(&viewer.image);
    assert_eq!(id, 4);
    assert!(
        left > right + 0.05,
        "upright: red on the left ({left} vs {right})"
    );
    for cancelled in [1, 2] {
        assert!(
            !viewer
                .log
                .iter()
                .any(|e| e["request"] == cancelled && e["final"] == true),
            "request {cancelled} was cancelled before its last image"
        );
    }
    viewer.finish();
}

#[test]
fn view_malformed_requests_get_error_events_and_change_nothing() {
    let mut viewer = Viewer::start("malformed", 2);
    let good = request(7, 16, false);
    let bad = [
        "not json".to_string(),
        "[1, 2]".to_string(),
        good.replace("\"width\":16", "\"width\":0"),
        good.replace("\"width\":16", "\"width\":100000"),
        good.replace("\"height\":16", "\"height\":16000")
            .replace("\"width\":16", "\"width\":16000"),
        good.replace("perspective", "fisheye"),
        good.replace("\"yfov\"", "\"fov\""),
        json!({"width": 16, "height": 16, "camera_to_world": [1, 2, 3],
               "projection": "perspective", "yfov": 0.5})
        .to_string(),
        json!({"width": 16, "height": 16, "camera_to_world": vec![0.0; 16],
               "projection": "perspective", "yfov": 0.5})
        .to_string(),
    ];
    let mut lines: Vec<Vec<u8>> = bad.iter().map(|l| l.as_bytes().to_vec()).collect();
    // Not UTF-8, and a line of a megabyte: answered like the others, and the lines after them
    // are still read.
    lines.push(b"{\"id\": \xff}".to_vec());
    lines.push(vec![b'x'; 1 << 20]);
    for (i, line) in lines.iter().enumerate() {
        assert_ne!(
            line,
            good.as_bytes(),
            "each bad request differs from the good one"
        );
        viewer.send_bytes(line);
        let error = viewer.wait(30.0, |e| e.get("error").is_some());
        let message = error["error"].as_str().unwrap();
        let start = format!("view request on line {}: ", i + 1);
        assert!(message.starts_with(&start), "{message}");
    }
    assert!(!viewer.image.exists(), "no image for a bad request");
    viewer.send(&good);
    viewer.image_of(7, true, 60.0);
    assert_eq!(read_image(&viewer.image).3, 7);
    viewer.finish();
}

#[test]
fn view_ends_when_stdin_closes_even_while_rendering() {
    let mut viewer = Viewer::start("stdin", 1_000_000);
    viewer.send(&request(1, 256, false));
    viewer.image_of(1, false, 30.0);
    let seconds = viewer.finish();
    assert!(seconds < 2.0, "took {seconds} s to end");
}

#[test]
fn view_photon_mapping_shows_a_full_size_path_traced_sample_before_its_maps() {
    let mut viewer = Viewer::start_with(
        "photon",
        &[
            "--method",
            "photon",
            "--spp",
            "2",
            "--photons",
            "4000",
            "--caustic-photons",
            "0",
        ],
    );
    viewer.send(&request(1, 32, false));
    viewer.image_of(1, true, 60.0);
    let images: Vec<(u64, u64)> = viewer
        .log
        .iter()
        .filter(|e| e["stage"] == "image")
        .map(|e| (e["width"].as_u64().unwrap(), e["spp"].as_u64().unwrap()))
        .collect();
    // Quarter size, full size (path traced), then the photon method's rounds of 1 and 1.
    assert_eq!(images, [(8, 1), (32, 1), (32, 1), (32, 2)]);
    let (w, h, spp, id, left, right) = read_image(&viewer.image);
    assert_eq!((w, h, spp, id), (32, 32, 2, 1));
    assert!(left > right + 0.05, "red on the left ({left} vs {right})");
    viewer.finish();
}

#[test]
fn view_refuses_render_only_flags_and_bad_scenes_with_exit_code_2() {
    let dir = temp_dir("flags");
    let image = dir.join("view.raw");
    let broken = dir.join("broken.glb");
    std::fs::write(&broken, b"not a glb").unwrap();
    for args in [
        vec!["view", "--time-limit", "1"],
        vec!["view", "--region", "0", "0", "4", "4"],
        vec!["view", broken.to_str().unwrap()],
    ] {
        let output = photon()
            .args(&args)
            .arg("-o")
            .arg(&image)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("photon: error:"), "{args:?}: {stderr}");
        assert!(!image.exists());
    }
    let _ = std::fs::remove_dir_all(dir);
}
