//! `photon view`: progressive rendering for an interactive viewer (the Blender add-on's Rendered
//! viewport). The scene is loaded and its BVH built once; then each line on stdin is a JSON
//! request naming a view (image size, camera pose and projection), answered by images of that
//! view that grow better: a quarter-resolution path-traced sample first (and, before the photon
//! and cache methods, which build their maps and cache for each view, a full-resolution one),
//! then the full resolution in rounds of 1, 1, 2, 4, … samples per pixel up to the settings'
//! samples, with the render settings' method. A new request cancels the render running (the
//! render's cancel flag, which it checks every few milliseconds) and starts on the new view; a
//! malformed request is answered by an error event and changes nothing; the end of stdin ends
//! the process (exit 0).
//!
//! Each image replaces the output file (written to a temporary name, then renamed): a 24-byte
//! header (`PHVW`, then little-endian u32 width, height, samples per pixel and u64 request id),
//! then width × height linear RGBA f32 pixels, little-endian, rows from the bottom up (as a GPU
//! texture is filled). After each image a JSON line on stderr says so:
//! `{"stage": "image", "request": ID, "width": W, "height": H, "spp": N, "final": bool,
//! "seconds": S}` (seconds since the request was read); a render a newer request stops is
//! followed by `{"stage": "cancelled", "request": ID, "by": NEWER, "seconds": S}` (seconds from
//! reading the newer request to the render's stop). The request protocol is specified in the
//! project README ("Interactive rendering"). Camera model as glTF's (Khronos glTF 2.0, §3.10),
//! with Blender's lens shift in units of the image height.

use photon::accel::Accel;
use photon::error::{Error, Result};
use photon::film::Image;
use photon::math::{Affine3A, Mat4, Vec2};
use photon::progress::{Progress, ProgressEvent};
use photon::render::{render_scheduled, Method, RenderSettings};
use photon::scene::{Camera, Projection, Scene};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

/// Largest image side a request may ask for.
const MAX_SIDE: u32 = 16_384;
/// Largest number of pixels a request may ask for (checked before any image is allocated).
const MAX_PIXELS: u64 = 64 << 20;
/// The first image's resolution divisor.
const PREVIEW_DIVISOR: u32 = 4;
/// Longest request line read, in bytes (a request is a few hundred).
const MAX_LINE: usize = 64 << 10;
/// Size of the image file's header in bytes.
pub const HEADER_BYTES: usize = 24;

/// One view to render.
#[derive(Clone, Debug)]
pub struct ViewRequest {
    pub id: u64,
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
}

/// What the stdin reader hands to the renderer: the newest request not yet started, and
/// whether stdin has ended.
#[derive(Default)]
struct Inbox {
    /// The request and when it was read.
    pending: Option<(ViewRequest, Instant)>,
    closed: bool,
}

/// The inbox, its signal and the cancel flag of the render running.
struct Shared {
    inbox: Mutex<Inbox>,
    wake: Condvar,
    cancel: AtomicBool,
}

impl Shared {
    fn post(&self, change: impl FnOnce(&mut Inbox)) {
        if let Ok(mut inbox) = self.inbox.lock() {
            change(&mut inbox);
            self.cancel.store(true, Ordering::SeqCst);
            self.wake.notify_all();
        }
    }
}

/// Serve view requests from stdin until it ends. `settings` are the render's (method, samples,
/// bounces, …); each request sets the size and the camera. `accel` is the scene's BVH if built.
pub fn serve(
    mut scene: Scene,
    accel: Option<Accel>,
    settings: &RenderSettings,
    pool: &rayon::ThreadPool,
    output: &Path,
) -> Result<()> {
    let accel = match accel {
        Some(accel) => accel,
        None => pool.install(|| Accel::new(&scene)),
    };
    let shared = Arc::new(Shared {
        inbox: Mutex::new(Inbox::default()),
        wake: Condvar::new(),
        cancel: AtomicBool::new(false),
    });
    let base = scene.camera.clone();
    let reader = {
        let shared = shared.clone();
        std::thread::spawn(move || read_requests(std::io::stdin().lock(), &base, &shared))
    };
    event(serde_json::json!({"stage": "ready", "fraction": 1.0,
                             "message": "waiting for view requests"}));
    loop {
        let request = {
            let mut inbox = shared
                .inbox
                .lock()
                .map_err(|_| Error::Internal("view request lock poisoned".into()))?;
            while inbox.pending.is_none() && !inbox.closed {
                inbox = shared
                    .wake
                    .wait(inbox)
                    .map_err(|_| Error::Internal("view request lock poisoned".into()))?;
            }
            if inbox.closed {
                break;
            }
            shared.cancel.store(false, Ordering::SeqCst);
            inbox.pending.take()
        };
        let Some((request, arrived)) = request else {
            continue;
        };
        scene.camera = request.camera.clone();
        // The frame's size: what pixel footprints (ray differentials) are measured against.
        scene.render_settings.width = Some(request.width);
        scene.render_settings.height = Some(request.height);
        let outcome = pool.install(|| {
            render_view(
                &scene,
                &accel,
                settings,
                &request,
                output,
                &shared.cancel,
                arrived,
            )
        });
        match outcome {
            Ok(()) => {}
            Err(Error::Cancelled) => {
                // How long the render took to stop after the request that cancelled it was
                // read (none when stdin ended).
                let since = shared.inbox.lock().ok().and_then(|inbox| {
                    let (next, read) = inbox.pending.as_ref()?;
                    Some((next.id, read.elapsed().as_secs_f64()))
                });
                if let Some((next, seconds)) = since {
                    event(
                        serde_json::json!({"stage": "cancelled", "request": request.id,
                                             "by": next, "seconds": seconds}),
                    );
                }
            }
            Err(e) => event(serde_json::json!({"stage": "view", "request": request.id,
                                               "error": e.to_string()})),
        }
    }
    let _ = reader.join();
    Ok(())
}

/// Read requests line by line until stdin ends; each valid one replaces the pending one and
/// cancels the render running, each invalid one (also one that is not UTF-8 or longer than
/// `MAX_LINE` bytes, which is not kept) is answered by an error event.
fn read_requests(mut input: impl BufRead, base: &Camera, shared: &Shared) {
    let mut bytes = Vec::new();
    for number in 1.. {
        bytes.clear();
        let mut too_long = false;
        loop {
            let limit = (MAX_LINE + 1).saturating_sub(bytes.len()) as u64;
            match std::io::Read::take(&mut input, limit).read_until(b'\n', &mut bytes) {
                Ok(_) if bytes.len() > MAX_LINE && !bytes.ends_with(b"\n") => {
                    // Drop what was read and go on to the end of the line.
                    too_long = true;
                    bytes.clear();
                }
                Ok(_) => break,
                Err(_) => {
                    bytes.clear();
                    break;
                }
            }
        }
        if bytes.is_empty() && !too_long {
            break; // the end of stdin (or a read error, which ends it too)
        }
        let outcome = match std::str::from_utf8(&bytes) {
            _ if too_long => Err(format!("longer than {MAX_LINE} bytes")),
            Err(_) => Err("not UTF-8 text".into()),
            Ok(line) if line.trim().is_empty() => continue,
            Ok(line) => parse_request(line, base),
        };
        match outcome {
            Ok(request) => shared.post(|inbox| inbox.pending = Some((request, Instant::now()))),
            Err(message) => event(serde_json::json!({"stage": "request", "error":
                format!("view request on line {number}: {message}")})),
        }
    }
    shared.post(|inbox| inbox.closed = true);
}

/// Parse one request line. The camera keeps `base`'s clip planes unless the request gives
/// them, and has no depth of field and no motion.
pub fn parse_request(line: &str, base: &Camera) -> std::result::Result<ViewRequest, String> {
    let value: serde_json::Value =
        serde_json::from_str(line).map_err(|e| format!("not JSON ({e})"))?;
    let object = value.as_object().ok_or("not a JSON object")?;
    for key in object.keys() {
        if !matches!(
            key.as_str(),
            "id" | "width"
                | "height"
                | "camera_to_world"
                | "projection"
                | "yfov"
                | "ymag"
                | "shift"
                | "clip"
        ) {
            return Err(format!("unknown field '{key}'"));
        }
    }
    let id = match object.get("id") {
        None => 0,
        Some(v) => v.as_u64().ok_or("'id' must be a whole number >= 0")?,
    };
    let side = |key: &str| -> std::result::Result<u32, String> {
        let v = object
            .get(key)
            .and_then(|v| v.as_u64())
            .ok_or(format!("'{key}' must be a whole number of pixels"))?;
        if v == 0 || v > MAX_SIDE as u64 {
            return Err(format!("'{key}' {v} is outside 1..={MAX_SIDE}"));
        }
        Ok(v as u32)
    };
    let (width, height) = (side("width")?, side("height")?);
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(format!("{width}x{height} is more than {MAX_PIXELS} pixels"));
    }
    let numbers = |key: &str, n: usize| -> std::result::Result<Vec<f32>, String> {
        let list = object
            .get(key)
            .and_then(|v| v.as_array())
            .filter(|list| list.len() == n)
            .ok_or(format!("'{key}' must be a list of {n} numbers"))?;
        list.iter()
            .map(|v| {
                v.as_f64()
                    .map(|x| x as f32)
                    .filter(|x| x.is_finite())
                    .ok_or(format!("'{key}' must hold finite numbers"))
            })
            .collect()
    };
    let number = |key: &str| -> std::result::Result<f32, String> {
        object
            .get(key)
            .and_then(|v| v.as_f64())
            .map(|x| x as f32)
            .filter(|x| x.is_finite())
            .ok_or(format!("'{key}' must be a finite number"))
    };
    let to_world = rigid(&numbers("camera_to_world", 16)?)?;
    let projection = match object.get("projection").and_then(|v| v.as_str()) {
        Some("perspective") => {
            let yfov = number("yfov")?;
            if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                return Err(format!("'yfov' {yfov} is outside (0, pi) radians"));
            }
            Projection::Perspective { yfov }
        }
        Some("orthographic") => {
            let ymag = number("ymag")?;
            if ymag <= 0.0 {
                return Err(format!("'ymag' {ymag} must be positive"));
            }
            let xmag = ymag * width as f32 / height as f32;
            Projection::Orthographic { xmag, ymag }
        }
        _ => return Err("'projection' must be \"perspective\" or \"orthographic\"".into()),
    };
    let shift = match object.get("shift") {
        None => Vec2::ZERO,
        Some(_) => {
            let s = numbers("shift", 2)?;
            Vec2::new(s[0], s[1])
        }
    };
    let (near_clip, far_clip) = match object.get("clip") {
        None => (base.near_clip, base.far_clip),
        Some(_) => {
            let c = numbers("clip", 2)?;
            if !(c[0] >= 0.0 && c[1] > c[0]) {
                return Err("'clip' must be [start, end] with 0 <= start < end".into());
            }
            (c[0], c[1])
        }
    };
    Ok(ViewRequest {
        id,
        width,
        height,
        camera: Camera {
            name: "view".into(),
            to_world,
            projection,
            aspect_ratio: None,
            shift,
            lens: None,
            motion: Vec::new(),
            near_clip,
            far_clip,
        },
    })
}

/// A row-major 4×4 camera-to-world matrix as a rigid transform: the last row must be
/// (0, 0, 0, 1) and the axes independent; they are normalised (a view matrix may carry scale).
fn rigid(m: &[f32]) -> std::result::Result<Affine3A, String> {
    let last_row = [m[12], m[13], m[14], m[15] - 1.0];
    if last_row.iter().any(|x| x.abs() > 1e-6) {
        return Err("'camera_to_world' must end with the row 0, 0, 0, 1".into());
    }
    let matrix = Mat4::from_cols_array(&[
        m[0], m[4], m[8], m[12], m[1], m[5], m[9], m[13], m[2], m[6], m[10], m[14], m[3], m[7],
        m[11], m[15],
    ]);
    let affine = Affine3A::from_mat4(matrix);
    let axes = [
        affine.matrix3.x_axis,
        affine.matrix3.y_axis,
        affine.matrix3.z_axis,
    ];
    if affine.matrix3.determinant().abs() < 1e-12 || axes.iter().any(|a| a.length() < 1e-6) {
        return Err("'camera_to_world' has no inverse".into());
    }
    let mut rigid = affine;
    rigid.matrix3.x_axis = axes[0].normalize();
    rigid.matrix3.y_axis = axes[1].normalize();
    rigid.matrix3.z_axis = axes[2].normalize();
    Ok(rigid)
}

/// Render one request: the quarter-resolution preview, then the full resolution in rounds,
/// writing each image and announcing it; returns `Err(Cancelled)` when a newer request came.
fn render_view(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    request: &ViewRequest,
    output: &Path,
    cancel: &AtomicBool,
    arrived: Instant,
) -> Result<()> {
    let quiet = |_: &ProgressEvent| {};
    let progress = Progress {
        cancel,
        report: &quiet,
    };
    let base = RenderSettings {
        width: request.width,
        height: request.height,
        region: None,
        light_passes: false,
        ..settings.clone()
    };
    let announce = |image: &Image, spp: u32, last: bool| -> Result<()> {
        write_view_image(output, image, spp, request.id)?;
        event(serde_json::json!({
            "stage": "image", "request": request.id, "width": image.width,
            "height": image.height, "spp": spp, "final": last,
            "seconds": arrived.elapsed().as_secs_f64(),
        }));
        Ok(())
    };
    // The first looks: one path-traced sample (no photon maps or cache to build) at a quarter
    // of the resolution, unless the image is already that small, and, before a method that
    // builds maps and a cache for each view (seconds), at the full resolution too.
    let mut divisors = Vec::new();
    if request.width >= 2 * PREVIEW_DIVISOR && request.height >= 2 * PREVIEW_DIVISOR {
        divisors.push(PREVIEW_DIVISOR);
    }
    if base.method != Method::Path {
        divisors.push(1);
    }
    for divisor in divisors {
        let preview = RenderSettings {
            width: request.width / divisor,
            height: request.height / divisor,
            spp: 1,
            method: Method::Path,
            adaptive: None,
            ..base.clone()
        };
        let mut first = None;
        render_scheduled(
            scene,
            Some(accel),
            &preview,
            &progress,
            &mut |done| match done {
                None => Some((preview.seed, 1)),
                Some((image, _)) => {
                    first = Some(image);
                    None
                }
            },
        )?;
        if let Some(image) = first {
            announce(&image, 1, false)?;
        }
    }
    let target = base.spp.max(1);
    let mut total: Option<Image> = None;
    let mut done_spp = 0u32;
    let mut rounds = 0u32;
    let mut failure = None;
    render_scheduled(scene, Some(accel), &base, &progress, &mut |done| {
        if let Some((image, spp)) = done {
            let image = match total.take() {
                None => image,
                Some(sum) => sum.merge(&image),
            };
            done_spp += spp;
            rounds += 1;
            if let Err(e) = announce(&image, done_spp, done_spp >= target) {
                failure = Some(e);
                return None;
            }
            total = Some(image);
        }
        if done_spp >= target || cancel.load(Ordering::Relaxed) {
            return None;
        }
        // Rounds of 1, 1, 2, 4, …: each about as long as all before it.
        let spp = done_spp.max(1).min(target - done_spp);
        Some((round_seed(base.seed, rounds), spp))
    })?;
    match failure {
        Some(e) => Err(e),
        None if cancel.load(Ordering::Relaxed) => Err(Error::Cancelled),
        None => Ok(()),
    }
}

/// Seed of round `index`: the settings' for the first, a well-mixed distinct one for the others.
fn round_seed(seed: u64, index: u32) -> u64 {
    seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
}

/// Write `image` as the view image file (header, then RGBA f32 rows from the bottom up) under a
/// temporary name, then rename it over `output`.
fn write_view_image(output: &Path, image: &Image, spp: u32, request: u64) -> Result<()> {
    let (w, h) = (image.width as usize, image.height as usize);
    let mut bytes = Vec::with_capacity(HEADER_BYTES + w * h * 16);
    bytes.extend_from_slice(b"PHVW");
    for v in [image.width, image.height, spp] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes.extend_from_slice(&request.to_le_bytes());
    for row in (0..h).rev() {
        for pixel in &image.rgba[row * w..(row + 1) * w] {
            for c in pixel {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let mut temporary = PathBuf::from(output);
    temporary.set_extension("partial");
    std::fs::write(&temporary, &bytes).map_err(|e| Error::io(&temporary, e))?;
    std::fs::rename(&temporary, output).map_err(|e| Error::io(output, e))
}

/// One JSON event line on stderr.
fn event(value: serde_json::Value) {
    let mut err = std::io::stderr().lock();
    let _ = writeln!(err, "{value}");
}
