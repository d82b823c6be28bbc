//! Ray throughput and start-up cost of the acceleration structure, for the speed figures of the
//! benchmark issue: load time, BVH build time, and million rays per second for primary rays
//! (closest hit), shadow rays towards a fixed direction (any hit) and diffuse-bounce rays
//! (closest hit, cosine-distributed from the primary hits), with 1 and 2 threads.
//!
//! `cargo run --release --example ray_throughput -- SCENE.glb [WIDTH]`
//! (`python3 scenes/make_large.py /tmp/large.glb` writes a 1-million-triangle scene.)

use photon::accel::{Accel, Ray, Visibility};
use photon::camera::CameraRays;
use photon::interaction::SurfaceHit;
use photon::math::{Frame, Vec2, Vec3};
use photon::rng::Rng;
use photon::sampling::square_to_cosine_hemisphere;
use photon::scene::gltf::{load, LoadOptions};
use photon::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Runs `f` over `items` on `threads` threads and returns (result, seconds).
fn timed<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> (T, f64) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let start = Instant::now();
    let out = pool.install(f);
    (out, start.elapsed().as_secs_f64())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: ray_throughput SCENE.glb [WIDTH]");
        std::process::exit(2);
    };
    let width: u32 = args.get(2).and_then(|w| w.parse().ok()).unwrap_or(512);
    let start = Instant::now();
    let scene: Scene = load(path.as_ref(), &LoadOptions::default()).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2);
    });
    let load_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let accel = Accel::new(&scene);
    let build_s = start.elapsed().as_secs_f64();
    println!(
        "{}: {} triangles; load {load_s:.3} s, BVH build {build_s:.3} s, start-up {:.3} s",
        path,
        accel.triangle_count(),
        load_s + build_s
    );
    let height = width;
    let camera = CameraRays::new(&scene.camera, width, height);
    let primary: Vec<Ray> = (0..width * height)
        .map(|i| {
            let film = Vec2::new((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
            camera.ray(film)
        })
        .collect();
    let light_dir = Vec3::new(0.4, 1.0, 0.3).normalize();
    for threads in [1, 2] {
        let (hits, primary_s) = timed(threads, || {
            primary
                .par_iter()
                .map(|ray| {
                    accel
                        .intersect(&scene, ray, Visibility::Camera)
                        .map(|hit| SurfaceHit::new(&scene, ray, &hit))
                })
                .collect::<Vec<_>>()
        });
        let hits: Vec<SurfaceHit> = hits.into_iter().flatten().collect();
        let (lit, shadow_s) = timed(threads, || {
            hits.par_iter()
                .filter(|h| accel.unoccluded(&scene, &h.spawn(light_dir)))
                .count()
        });
        let bounce: Vec<Ray> = hits
            .iter()
            .enumerate()
            .map(|(i, h)| {
                let mut rng = Rng::for_item(1, i as u64, 0);
                let n = if h.ng.dot(h.frame.n) < 0.0 {
                    -h.ng
                } else {
                    h.ng
                };
                h.spawn(Frame::from_normal(n).to_world(square_to_cosine_hemisphere(rng.uniform2())))
            })
            .collect();
        let (found, bounce_s) = timed(threads, || {
            bounce
                .par_iter()
                .filter(|r| accel.intersect(&scene, r, Visibility::Secondary).is_some())
                .count()
        });
        let rate = |n: usize, s: f64| n as f64 / s / 1e6;
        println!(
            "{threads} thread(s): primary {:.2} Mrays/s ({} rays, {} hits), shadow {:.2} Mrays/s \
             ({} unoccluded), diffuse bounce {:.2} Mrays/s ({} hits)",
            rate(primary.len(), primary_s),
            primary.len(),
            hits.len(),
            rate(hits.len(), shadow_s),
            lit,
            rate(bounce.len(), bounce_s),
            found
        );
    }
}
