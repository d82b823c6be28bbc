//! One frame split across machines: `photon render --sample-offset` renders of disjoint sample
//! ranges of the embedded Cornell box, merged by `photon merge`, equal one render of all the
//! samples (every pass, to float rounding), for the path tracer and for the photon method
//! across a generation of photon maps; the merged photon render is as close to a converged
//! path-traced reference as the single one. Inputs that cannot be merged exit with 2.

use crate::support::binary::{assert_success, photon, temp_dir};
use exr::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

const SIZE: [&str; 4] = ["--width", "16", "--height", "12"];

/// `photon render` of the Cornell box into `dir/name` with `args`, as a Blender multilayer EXR
/// with the light passes.
fn render(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let output = photon()
        .arg("render")
        .arg("-o")
        .arg(&out)
        .args(SIZE)
        .args(["--exr-layer", "ViewLayer", "--passes"])
        .args(args)
        .output()
        .unwrap();
    assert_success(&output);
    out
}

fn merge(output: &Path, inputs: &[&Path]) -> Output {
    photon()
        .arg("merge")
        .arg(output)
        .args(inputs)
        .output()
        .unwrap()
}

/// Every channel of an EXR by name, and its text attributes.
fn read(path: &Path) -> (BTreeMap<String, Vec<f32>>, BTreeMap<String, String>) {
    let image = read_all_flat_layers_from_file(path).expect("readable EXR");
    let layer = &image.layer_data[0];
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values = c.sample_data.values_as_f32().collect();
            (c.name.to_string(), values)
        })
        .collect();
    let attributes = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    (channels, attributes)
}

/// Assert that every channel of `merged` but Depth and the normals equals `whole`'s to float
/// rounding; Depth where every sample of the pixel hit something (most pixels, and close
/// elsewhere); the normals, unit vectors averaged and normalised again, where the pixel's
/// samples saw one surface (and close where they saw several).
fn assert_same_render(merged: &Path, whole: &Path) {
    let (m, m_attributes) = read(merged);
    let (w, w_attributes) = read(whole);
    assert_eq!(
        m.keys().collect::<Vec<_>>(),
        w.keys().collect::<Vec<_>>(),
        "the merge has the render's channels"
    );
    assert_eq!(
        m_attributes["photon.samples"],
        w_attributes["photon.samples"]
    );
    for (name, values) in &m {
        let reference = &w[name];
        if name.contains("Normal.") {
            continue;
        }
        if name.ends_with(".Depth.Z") {
            // Exact where every sample hit something; where some missed (the box's open front,
            // the light's edges) the parts' means are weighted by samples rather than by hits.
            let close = |a: &f32, b: &f32| (a - b).abs() <= 1e-5 * b.abs();
            let same = values
                .iter()
                .zip(reference)
                .filter(|(a, b)| close(a, b))
                .count();
            let worst = values
                .iter()
                .zip(reference)
                .map(|(a, b)| (a - b).abs() / b)
                .fold(0.0f32, f32::max);
            eprintln!(
                "{name}: {same} of {} pixels equal, worst relative difference {worst}",
                values.len()
            );
            assert!(same * 10 >= values.len() * 7 && worst < 0.02);
            continue;
        }
        for (k, (a, b)) in values.iter().zip(reference).enumerate() {
            assert!(
                (a - b).abs() <= 1e-5 * b.abs().max(1.0),
                "{name} pixel {k}: merged {a}, whole {b}"
            );
        }
    }
    for pass in ["ViewLayer.Normal", "ViewLayer.Denoising Normal"] {
        let vector = |c: &BTreeMap<String, Vec<f32>>, k: usize| {
            ["X", "Y", "Z"].map(|axis| c[&format!("{pass}.{axis}")][k])
        };
        let pixels = m[&format!("{pass}.X")].len();
        let (mut same, mut least_cos) = (0, 1.0f32);
        for k in 0..pixels {
            let (a, b) = (vector(&m, k), vector(&w, k));
            if (0..3).all(|i| (a[i] - b[i]).abs() <= 1e-5) {
                same += 1;
                continue;
            }
            least_cos = least_cos.min((0..3).map(|i| a[i] * b[i]).sum());
        }
        eprintln!("{pass}: {same} of {pixels} pixels equal, least cosine {least_cos}");
        assert!(same * 2 >= pixels, "{pass}: {same} of {pixels} equal");
        assert!(least_cos > 0.95, "{pass}: cosine {least_cos}");
    }
}

#[test]
fn frame_split_path_tracer_parts_merge_into_the_whole() {
    let dir = temp_dir("path");
    let common = ["--method", "path", "--seed", "5"];
    let part = |name: &str, offset: &str, spp: &str| {
        let args = [&common[..], &["--sample-offset", offset, "--spp", spp]].concat();
        render(&dir, name, &args)
    };
    let (a, b) = (part("a.exr", "0", "4"), part("b.exr", "4", "4"));
    let whole = part("whole.exr", "0", "8");
    let merged = dir.join("merged.exr");
    // In either order.
    assert_success(&merge(&merged, &[&b, &a]));
    assert_same_render(&merged, &whole);
    let (_, attributes) = read(&merged);
    assert_eq!(attributes["photon.samples"], "0-8 seed 5");
    // A part alone is not the whole: the offset renders other samples.
    let (pa, pw) = (read(&a).0, read(&whole).0);
    assert_ne!(pa["ViewLayer.Combined.R"], pw["ViewLayer.Combined.R"]);
    let pb = read(&b).0;
    assert_ne!(pa["ViewLayer.Combined.R"], pb["ViewLayer.Combined.R"]);
}

#[test]
fn frame_split_photon_parts_across_a_generation_merge_into_the_whole() {
    let dir = temp_dir("photon");
    // Generations change every 64 samples: the middle part starts in generation 0 and ends in
    // generation 1, whose maps it must build as the whole render does.
    let common = [
        "--method",
        "photon",
        "--photons",
        "20000",
        "--caustic-photons",
        "5000",
        "--seed",
        "3",
    ];
    let part = |name: &str, offset: &str, spp: &str| {
        let args = [&common[..], &["--sample-offset", offset, "--spp", spp]].concat();
        render(&dir, name, &args)
    };
    let parts = [
        part("a.exr", "0", "40"),
        part("b.exr", "40", "48"),
        part("c.exr", "88", "40"),
    ];
    let whole = part("whole.exr", "0", "128");
    let merged = dir.join("merged.exr");
    assert_success(&merge(&merged, &[&parts[0], &parts[1], &parts[2]]));
    assert_same_render(&merged, &whole);
    // Against a converged path-traced reference, the merged render is the whole one's match.
    let reference = render(
        &dir,
        "reference.exr",
        &["--method", "path", "--spp", "1024", "--seed", "9"],
    );
    let rgb = |p: &Path| photon::image_io::read_exr_rgba(p).unwrap().2;
    let e_merged = photon::metrics::compare(&rgb(&merged), &rgb(&reference)).rel_mse;
    let e_whole = photon::metrics::compare(&rgb(&whole), &rgb(&reference)).rel_mse;
    let e_part = photon::metrics::compare(&rgb(&parts[0]), &rgb(&reference)).rel_mse;
    eprintln!(
        "relMSE against the reference: merged {e_merged}, whole {e_whole}, part [0, 40) {e_part}"
    );
    assert!(
        (e_merged - e_whole).abs() <= 1e-4 * e_whole,
        "relMSE merged {e_merged}, whole {e_whole}"
    );
    assert!(e_merged < e_part, "merged {e_merged}, one part {e_part}");
}

/// An EXR with one channel `R` (and G, B) of `w` × `h` and the given text attributes.
fn write_exr(path: &Path, (w, h): (usize, usize), names: &[&str], attributes: &[(&str, &str)]) {
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = names
        .iter()
        .map(|n| AnyChannel::new(*n, FlatSamples::F32(vec![0.5; w * h])))
        .collect();
    let mut layer_attributes = LayerAttributes::default();
    for (k, v) in attributes {
        layer_attributes.other.insert(
            Text::from(*k),
            exr::meta::attribute::AttributeValue::Text(Text::from(*v)),
        );
    }
    let layer = Layer::new(
        (w, h),
        layer_attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    exr::image::Image::from_layer(layer)
        .write()
        .to_file(path)
        .unwrap();
}

#[test]
fn frame_split_inputs_that_cannot_be_merged_exit_with_2() {
    let dir = temp_dir("bad");
    let rgb = ["L.Combined.R", "L.Combined.G", "L.Combined.B"];
    let with = |seed: &str, ranges: &str| [("photon.samples", format!("{ranges} seed {seed}"))];
    let file = |name: &str, size: (usize, usize), names: &[&str], attrs: &[(String, String)]| {
        let path = dir.join(name);
        let attrs: Vec<(&str, &str)> = attrs
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        write_exr(&path, size, names, &attrs);
        path
    };
    let kv = |a: [(&str, String); 1]| a.map(|(k, v)| (k.to_string(), v)).to_vec();
    let a = file("a.exr", (4, 3), &rgb, &kv(with("1", "0-4")));
    let b = file("b.exr", (4, 3), &rgb, &kv(with("1", "4-8")));
    let overlapping = file("overlap.exr", (4, 3), &rgb, &kv(with("1", "2-6")));
    let other_seed = file("seed.exr", (4, 3), &rgb, &kv(with("2", "4-8")));
    let other_size = file("size.exr", (5, 3), &rgb, &kv(with("1", "4-8")));
    let more = [&rgb[..], &["L.DiffDir.R", "L.DiffDir.G", "L.DiffDir.B"]].concat();
    let other_passes = file("passes.exr", (4, 3), &more, &kv(with("1", "4-8")));
    let other_layer = file(
        "layer.exr",
        (4, 3),
        &["M.Combined.R", "M.Combined.G", "M.Combined.B"],
        &kv(with("1", "4-8")),
    );
    let noisy = [&rgb[..], &["L.Noisy Image.R", "L.Noisy Image.G"]].concat();
    let denoised = file("denoised.exr", (4, 3), &noisy, &kv(with("1", "4-8")));
    let unrecorded = file("plain.exr", (4, 3), &rgb, &[]);
    let garbled = file("garbled.exr", (4, 3), &rgb, &kv(with("1", "8-4")));
    let not_exr = dir.join("not.exr");
    std::fs::write(&not_exr, b"not an image").unwrap();
    let out = dir.join("out.exr");
    assert_success(&merge(&out, &[&a, &b]));
    for (case, words) in [
        (&overlapping, "both hold samples 2-4"),
        (&other_seed, "seed 2 against 1"),
        (&other_size, "5x3 pixels against 4x3"),
        (&other_passes, "L.DiffDir"),
        (&other_layer, "M.Combined"),
        (&denoised, "denoised"),
        (&unrecorded, "records no samples"),
        (&garbled, "is not a range"),
        (&not_exr, "not.exr"),
        (&dir.join("missing.exr"), "missing.exr"),
    ] {
        let _ = std::fs::remove_file(&out);
        let output = merge(&out, &[&a, case]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{}: {stderr}",
            case.display()
        );
        assert!(stderr.contains(words), "{}: {stderr}", case.display());
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists(), "{}: no output on failure", case.display());
    }
    // One input is not a merge.
    assert_eq!(merge(&out, &[&a]).status.code(), Some(2));
    // An offset needs known sample ranges: no time limit, no adaptive sampling.
    for extra in [
        &["--time-limit", "1"][..],
        &["--adaptive-threshold", "0.01"][..],
    ] {
        let output = photon()
            .args(["render", "-o"])
            .arg(dir.join("x.exr"))
            .args(SIZE)
            .args(["--spp", "2", "--sample-offset", "2"])
            .args(extra)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains("sample offset") || stderr.contains("--sample-offset"));
    }
}
