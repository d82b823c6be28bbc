//! Writing and reading images: OpenEXR (linear float, the renderer's real output) and PNG (a
//! tone-mapped sRGB preview). Files are written to a temporary name beside the target and renamed,
//! so a failed or cancelled run never leaves a half-written image where the user expects theirs.

use crate::error::{Error, Result};
use crate::film::Image;
use crate::light_pass::LightPass;
use crate::math::{linear_to_srgb, Vec3};
use exr::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// How EXR channels are named.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExrLayout {
    /// Plain R, G, B, A: what image viewers and compositing tools expect.
    Rgba,
    /// Blender's multilayer naming `<view layer>.<pass>.<channel>` (Combined, Depth, Normal,
    /// Denoising Albedo, Denoising Normal), which `RenderResult.load_from_file` reads; with
    /// `light_passes`, also the light-path passes under the names in `LIGHT_PASS_NAMES` (the
    /// volume passes only when the image has volume light); and Cycles' Shadow Catcher pass
    /// when the scene has a shadow catcher (`Image::shadow_catcher`).
    Blender {
        view_layer: String,
        light_passes: bool,
    },
}

/// Blender pass names of the light-path passes, in `LightPass` order. Emission, Direct and
/// Indirect use the names of Blender's own view-layer passes (Emission, Diffuse Direct, Diffuse
/// Indirect, which Photon fills with all of its direct and indirect light from surfaces, glossy
/// included), Volume Direct and Indirect those of Cycles' (`VolumeDir`, `VolumeInd`); Caustic
/// and Subsurface have no Blender counterpart and are the add-on's own.
pub const LIGHT_PASS_NAMES: [&str; 7] = [
    "Emit",
    "DiffDir",
    "DiffInd",
    "Caustic",
    "Subsurface",
    "VolumeDir",
    "VolumeInd",
];

/// The light passes written only when some pixel has light in them (images of scenes without
/// media keep the channels they always had); Blender leaves a pass the file lacks black.
const WRITTEN_WHEN_LIT: [LightPass; 2] = [LightPass::VolumeDirect, LightPass::VolumeIndirect];

/// The temporary path a file is written to before it is renamed to `path`.
pub fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.photon-{}.tmp", std::process::id()))
}

/// Write with `write` to a temporary file, then rename it over `path` unless `cancel` was set
/// meanwhile. The temporary file is removed on every failure.
pub fn write_atomically(
    path: &Path,
    cancel: &AtomicBool,
    write: impl FnOnce(&Path) -> Result<()>,
) -> Result<()> {
    let tmp = temporary_path(path);
    let result = write(&tmp).and_then(|()| {
        if cancel.load(Ordering::Relaxed) {
            Err(Error::Cancelled)
        } else {
            std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
        }
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Write `image` to `path` as EXR (`.exr`) or PNG (`.png`), chosen by the extension.
pub fn write_image(
    path: &Path,
    image: &Image,
    layout: &ExrLayout,
    cancel: &AtomicBool,
) -> Result<()> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("exr") => write_atomically(path, cancel, |tmp| write_exr(tmp, path, image, layout)),
        Some("png") => write_atomically(path, cancel, |tmp| write_png(tmp, path, image)),
        _ => Err(Error::Settings(format!(
            "{}: unknown output format (use .exr or .png)",
            path.display()
        ))),
    }
}

fn exr_channels(image: &Image, layout: &ExrLayout) -> Vec<(String, Vec<f32>)> {
    let plane = |f: &dyn Fn(usize) -> f32| (0..image.rgba.len()).map(f).collect::<Vec<f32>>();
    let rgba = |c: usize| plane(&|i| image.rgba[i][c]);
    let vec3 = |v: &[Vec3], c: usize| plane(&|i| v[i][c]);
    match layout {
        ExrLayout::Rgba => vec![
            ("R".into(), rgba(0)),
            ("G".into(), rgba(1)),
            ("B".into(), rgba(2)),
            ("A".into(), rgba(3)),
        ],
        ExrLayout::Blender {
            view_layer,
            light_passes,
        } => {
            let name = |pass: &str, chan: &str| format!("{view_layer}.{pass}.{chan}");
            let mut channels = vec![
                (name("Combined", "R"), rgba(0)),
                (name("Combined", "G"), rgba(1)),
                (name("Combined", "B"), rgba(2)),
                (name("Combined", "A"), rgba(3)),
                (name("Depth", "Z"), plane(&|i| image.depth[i])),
                (name("Normal", "X"), vec3(&image.normal, 0)),
                (name("Normal", "Y"), vec3(&image.normal, 1)),
                (name("Normal", "Z"), vec3(&image.normal, 2)),
                (
                    name("Denoising Normal", "X"),
                    plane(&|i| image.camera_space_normal(i).x),
                ),
                (
                    name("Denoising Normal", "Y"),
                    plane(&|i| image.camera_space_normal(i).y),
                ),
                (
                    name("Denoising Normal", "Z"),
                    plane(&|i| image.camera_space_normal(i).z),
                ),
                (name("Denoising Albedo", "R"), vec3(&image.albedo, 0)),
                (name("Denoising Albedo", "G"), vec3(&image.albedo, 1)),
                (name("Denoising Albedo", "B"), vec3(&image.albedo, 2)),
            ];
            if !image.shadow_catcher.is_empty() {
                for (c, chan) in ["R", "G", "B"].iter().enumerate() {
                    channels.push((name("Shadow Catcher", chan), vec3(&image.shadow_catcher, c)));
                }
            }
            if *light_passes {
                for (p, pass) in LIGHT_PASS_NAMES.iter().enumerate() {
                    let lit = || image.passes.iter().any(|v| v.0[p] != Vec3::ZERO);
                    if WRITTEN_WHEN_LIT.contains(&LightPass::ALL[p]) && !lit() {
                        continue;
                    }
                    for (c, chan) in ["R", "G", "B"].iter().enumerate() {
                        let values = plane(&|i| image.passes[i].0[p][c]);
                        channels.push((name(pass, chan), values));
                    }
                }
            }
            channels
        }
    }
}

fn write_exr(tmp: &Path, target: &Path, image: &Image, layout: &ExrLayout) -> Result<()> {
    if let ExrLayout::Blender {
        light_passes: true, ..
    } = layout
    {
        if image.passes.len() != image.rgba.len() {
            return Err(Error::Settings(
                "the light passes were not rendered (RenderSettings::light_passes)".into(),
            ));
        }
    }
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = exr_channels(image, layout)
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data)))
        .collect();
    let mut attributes = LayerAttributes::default();
    for (name, value) in &image.metadata {
        let text = |t: &str| {
            Text::new_or_none(t).ok_or_else(|| {
                Error::Settings(format!("EXR attribute {name}: not writable as EXR text"))
            })
        };
        attributes
            .other
            .insert(text(name)?, AttributeValue::Text(text(value)?));
    }
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    exr::image::Image::from_layer(layer)
        .write()
        .to_file(tmp)
        .map_err(|e| Error::io(target, std::io::Error::other(e.to_string())))
}

/// Linear radiance to an 8-bit sRGB value (Blender's "Standard" view transform: clip, encode).
pub fn to_srgb8(v: f32) -> u8 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    (linear_to_srgb(v) * 255.0 + 0.5) as u8
}

fn write_png(tmp: &Path, target: &Path, image: &Image) -> Result<()> {
    let io = |e: std::io::Error| Error::io(target, e);
    let file = std::fs::File::create(tmp).map_err(io)?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), image.width, image.height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .map_err(|e| io(std::io::Error::other(e.to_string())))?;
    let data: Vec<u8> = image
        .rgba
        .iter()
        .flat_map(|p| {
            let a = if p[3].is_finite() {
                p[3].clamp(0.0, 1.0)
            } else {
                0.0
            };
            [
                to_srgb8(p[0]),
                to_srgb8(p[1]),
                to_srgb8(p[2]),
                (a * 255.0 + 0.5) as u8,
            ]
        })
        .collect();
    writer
        .write_image_data(&data)
        .map_err(|e| io(std::io::Error::other(e.to_string())))?;
    writer
        .finish()
        .map_err(|e| io(std::io::Error::other(e.to_string())))
}

/// Read the R, G, B (and A, 1 when absent) channels of an EXR file, top row first, with any
/// layer prefix ("ViewLayer.Combined.R" counts as R).
pub fn read_exr_rgba(path: &Path) -> Result<(u32, u32, Vec<[f32; 4]>)> {
    let bad = |m: String| Error::scene(path, "EXR", m);
    let image = read_all_flat_layers_from_file(path).map_err(|e| bad(e.to_string()))?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| bad("no layer".into()))?;
    let (w, h) = (layer.size.width(), layer.size.height());
    let mut out = vec![[0.0, 0.0, 0.0, 1.0]; w * h];
    let mut found = 0;
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        let short = name.rsplit('.').next().unwrap_or("");
        let Some(c) = ["R", "G", "B", "A"].iter().position(|&n| n == short) else {
            continue;
        };
        // In a multilayer file only the Combined pass is read.
        if name.contains('.') && !name.contains(".Combined.") {
            continue;
        }
        for (i, v) in channel.sample_data.values_as_f32().enumerate().take(w * h) {
            out[i][c] = v;
        }
        found += 1;
    }
    if found < 3 {
        return Err(bad("no R, G, B channels".into()));
    }
    Ok((w as u32, h as u32, out))
}
