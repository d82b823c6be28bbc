//! One frame split across machines: the samples an EXR holds (its header's sample ranges) and
//! the merge of renders of disjoint sample ranges into the render of their union, after
//! Cycles' Sample Offset and its image merging (Blender's `intern/cycles/session/merge.cpp`,
//! 2022): every pass that is a mean over samples is averaged weighted by each file's sample
//! count, so renders of samples [0, a) and [a, b) merge into the render of [0, b) up to float
//! rounding.
//!
//! Which passes are means: all, with two qualifications. Depth is the mean distance of the
//! samples that hit something (`film::NO_HIT_DEPTH` where none did), so it is averaged over
//! the files whose samples hit something there, as `film::Image::merge` joins a render's
//! rounds: exact where every sample hits, a mean weighted by samples rather than by hits at
//! silhouettes (Cycles copies the first file's Depth instead, its depth being one sample's).
//! The normals (Normal, Denoising Normal) are unit vectors, the normalised sum of the samples'
//! normals: they are averaged and made unit length again, exact where the pixel's samples see
//! one surface, close where they see several. A denoised image (one with Blender's Noisy Image
//! pass) is refused: denoising is not linear in the samples, so the parts are merged noisy and
//! the merged image denoised.
//!
//! The merge is one part holding every channel, whether the inputs are one part (the renderer's
//! files, Blender 4's multilayer files) or a part a pass (Blender 5's).
//!
//! Everything is checked from the headers before any pixel is read: the files must have the
//! same size and channels (Volume Direct and Indirect may be missing from some, as the
//! renderer leaves them out when nothing in the image has volume light: they count as black
//! there), the same seed, and sample ranges that do not overlap.

use crate::error::{Error, Result};
use crate::film::NO_HIT_DEPTH;
use crate::image_io::write_atomically;
use exr::meta::attribute::{AttributeValue, Text};
use exr::meta::MetaData;
use exr::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// The header attribute that records the samples an image holds: the half-open ranges of the
/// pixels' sample sequence, `first-end` separated by commas, then the sequence's seed:
/// "0-16 seed 1", "0-16,32-48 seed 7". One attribute, so that the header's bytes do not depend
/// on the order the EXR writer lists attributes in.
pub const SAMPLES_KEY: &str = "photon.samples";

/// Passes that may be missing from some files (written only when lit), counting as black.
const OPTIONAL_PASSES: [&str; 2] = ["VolumeDir", "VolumeInd"];
/// Passes of unit vectors: averaged, then normalised.
const NORMAL_PASSES: [&str; 2] = ["Normal", "Denoising Normal"];

/// The samples of the pixels' sequence (from `seed`) an image holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SampleRanges {
    pub seed: u64,
    /// Sorted, disjoint, non-empty half-open ranges, adjacent ones joined.
    pub ranges: Vec<(u32, u32)>,
}

impl SampleRanges {
    /// Samples `offset .. offset + spp`.
    pub fn single(seed: u64, offset: u32, spp: u32) -> Self {
        SampleRanges {
            seed,
            ranges: vec![(offset, offset.saturating_add(spp))],
        }
    }

    /// Samples per pixel.
    pub fn count(&self) -> u64 {
        self.ranges.iter().map(|&(a, b)| (b - a) as u64).sum()
    }

    /// The header attribute that records them (`SAMPLES_KEY`).
    pub fn metadata(&self) -> Vec<(String, String)> {
        let ranges: Vec<String> = self
            .ranges
            .iter()
            .map(|(a, b)| format!("{a}-{b}"))
            .collect();
        let text = format!("{} seed {}", ranges.join(","), self.seed);
        vec![(SAMPLES_KEY.into(), text)]
    }

    /// Read from the attributes `get` looks up; `None` when the samples are not recorded.
    pub fn parse(
        get: impl Fn(&str) -> Option<String>,
    ) -> std::result::Result<Option<Self>, String> {
        let Some(text) = get(SAMPLES_KEY) else {
            return Ok(None);
        };
        let bad = |what: &str| format!("{SAMPLES_KEY} {text:?}: {what} (expected \"0-16 seed 1\")");
        let (ranges, seed) = text.split_once(" seed ").ok_or_else(|| bad("no seed"))?;
        let seed = seed
            .trim()
            .parse::<u64>()
            .map_err(|_| bad("the seed is not a number"))?;
        let mut all = SampleRanges {
            seed,
            ranges: Vec::new(),
        };
        for part in ranges.split(',') {
            let range = part.split_once('-').and_then(|(a, b)| {
                let (a, b) = (a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?);
                (a < b).then_some((a, b))
            });
            let range = range.ok_or_else(|| bad(&format!("{part:?} is not a range FIRST-END")))?;
            all = all
                .union(&SampleRanges {
                    seed,
                    ranges: vec![range],
                })
                .map_err(|(a, b)| bad(&format!("the ranges overlap at {a}-{b}")))?;
        }
        Ok(Some(all))
    }

    /// Both sets of samples, or the first overlapping range when they share samples.
    pub fn union(&self, other: &SampleRanges) -> std::result::Result<SampleRanges, (u32, u32)> {
        let mut all: Vec<(u32, u32)> = self.ranges.iter().chain(&other.ranges).copied().collect();
        all.sort_unstable();
        let mut joined: Vec<(u32, u32)> = Vec::with_capacity(all.len());
        for (a, b) in all {
            match joined.last_mut() {
                Some(last) if a < last.1 => return Err((a, b.min(last.1))),
                Some(last) if a == last.1 => last.1 = b,
                _ => joined.push((a, b)),
            }
        }
        Ok(SampleRanges {
            seed: self.seed,
            ranges: joined,
        })
    }
}

/// How a channel is merged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rule {
    /// The sample-weighted mean.
    Mean,
    /// The sample-weighted mean of a unit vector, normalised afterwards.
    UnitMean,
    /// The sample-weighted mean over the files that hold a value there (Depth: not `NO_HIT`).
    HitMean,
}

/// The pass of a channel named `<view layer>.<pass>.<channel>` (Blender's multilayer names),
/// `None` for plain names (R, G, B, A).
fn pass_of(channel: &str) -> Option<&str> {
    let (rest, _) = channel.rsplit_once('.')?;
    Some(rest.rsplit_once('.').map_or(rest, |(_, pass)| pass))
}

fn rule(channel: &str) -> Rule {
    match pass_of(channel) {
        Some("Depth") => Rule::HitMean,
        Some(pass) if NORMAL_PASSES.contains(&pass) => Rule::UnitMean,
        None if channel == "Z" => Rule::HitMean,
        _ => Rule::Mean,
    }
}

/// One input's header: what is checked before its pixels are read.
struct Input {
    path: PathBuf,
    size: (usize, usize),
    channels: Vec<String>,
    samples: SampleRanges,
    attributes: HashMap<Text, AttributeValue>,
}

fn read_header(path: &Path) -> Result<Input> {
    let bad = |m: String| Error::scene(path, "EXR", m);
    let meta = MetaData::read_from_file(path, false).map_err(|e| match e {
        exr::error::Error::Io(io) => Error::io(path, io),
        e => bad(e.to_string()),
    })?;
    // Blender 4 writes a multilayer file as one part, Blender 5 as a part a pass: the
    // channels of all parts, which must have one size, and the samples from whichever part
    // records them (the first).
    let Some(first) = meta.headers.first() else {
        return Err(bad("has no parts".into()));
    };
    let size = first.layer_size;
    let mut channels: Vec<String> = Vec::new();
    for header in &meta.headers {
        if header.deep {
            return Err(bad("is a deep image, which cannot be merged".into()));
        }
        if header.layer_size != size {
            return Err(bad("has parts of different sizes".into()));
        }
        for c in &header.channels.list {
            let name = c.name.to_string();
            if channels.contains(&name) {
                return Err(bad(format!("has the channel {name} twice")));
            }
            channels.push(name);
        }
    }
    let text = |header: &exr::meta::header::Header| match header
        .own_attributes
        .other
        .get(&Text::from(SAMPLES_KEY))
    {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    };
    let recorded = meta.headers.iter().find_map(text);
    let attributes = meta
        .headers
        .iter()
        .find(|h| text(h).is_some())
        .unwrap_or(first)
        .own_attributes
        .other
        .clone();
    let samples = SampleRanges::parse(|_| recorded.clone())
        .map_err(bad)?
        .ok_or_else(|| {
            bad(format!(
                "records no samples ({SAMPLES_KEY}): only renders by photon render, or by the \
                 Blender add-on, can be merged"
            ))
        })?;
    if let Some(c) = channels.iter().find(|c| pass_of(c) == Some("Noisy Image")) {
        return Err(bad(format!(
            "is denoised (it has the {c} channel): denoising does not average, so render the \
             parts with Denoise off, merge them, then denoise the merged image"
        )));
    }
    Ok(Input {
        path: path.to_path_buf(),
        size: (size.width(), size.height()),
        channels,
        samples,
        attributes,
    })
}

/// Check that `inputs` can be merged and return the samples of the merge.
fn check(inputs: &[Input]) -> Result<SampleRanges> {
    let first = &inputs[0];
    let optional = |c: &String| pass_of(c).is_some_and(|p| OPTIONAL_PASSES.contains(&p));
    let required = |i: &Input| -> Vec<String> {
        let mut c: Vec<String> = i
            .channels
            .iter()
            .filter(|c| !optional(c))
            .cloned()
            .collect();
        c.sort();
        c
    };
    let mut samples = first.samples.clone();
    for input in &inputs[1..] {
        let refuse = |m: String| {
            Error::Settings(format!(
                "cannot merge {} with {}: {m}",
                input.path.display(),
                first.path.display()
            ))
        };
        if input.size != first.size {
            return Err(refuse(format!(
                "{}x{} pixels against {}x{}",
                input.size.0, input.size.1, first.size.0, first.size.1
            )));
        }
        let (a, b) = (required(first), required(input));
        if a != b {
            let only = |x: &[String], y: &[String]| {
                x.iter()
                    .filter(|c| !y.contains(c))
                    .take(4)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(refuse(format!(
                "different passes or view layers (only in the first: [{}]; only in this one: [{}])",
                only(&a, &b),
                only(&b, &a)
            )));
        }
        if input.samples.seed != samples.seed {
            return Err(refuse(format!(
                "seed {} against {}: the parts of a split frame render one sample sequence",
                input.samples.seed, samples.seed
            )));
        }
        samples = samples.union(&input.samples).map_err(|(a, b)| {
            refuse(format!(
                "both hold samples {a}-{b} (render each part with its own --sample-offset)"
            ))
        })?;
    }
    Ok(samples)
}

/// What `merge` did.
pub struct MergeSummary {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub samples: SampleRanges,
}

/// Merge the renders `inputs` (EXR files of disjoint sample ranges of one frame) into `output`.
pub fn merge(inputs: &[PathBuf], output: &Path, cancel: &AtomicBool) -> Result<MergeSummary> {
    if inputs.len() < 2 {
        return Err(Error::Settings("merge needs at least two images".into()));
    }
    let headers = inputs
        .iter()
        .map(|p| read_header(p))
        .collect::<Result<Vec<_>>>()?;
    let samples = check(&headers)?;
    let (w, h) = headers[0].size;
    let total = samples.count() as f64;
    // Every channel of any input, in a fixed order; weighted sums in f64, and for `HitMean`
    // channels the weights summed.
    let mut sums: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut weights: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for input in &headers {
        for c in &input.channels {
            sums.entry(c.clone()).or_insert_with(|| vec![0.0; w * h]);
            if rule(c) == Rule::HitMean {
                weights.entry(c.clone()).or_insert_with(|| vec![0.0; w * h]);
            }
        }
    }
    for input in &headers {
        let bad = |m: String| Error::scene(&input.path, "EXR", m);
        let image = read_all_flat_layers_from_file(&input.path).map_err(|e| bad(e.to_string()))?;
        let weight = input.samples.count() as f64 / total;
        for channel in image.layer_data.iter().flat_map(|l| &l.channel_data.list) {
            let name = channel.name.to_string();
            let sum = sums
                .get_mut(&name)
                .ok_or_else(|| bad(format!("channel {name} is not in its header")))?;
            let values = channel.sample_data.values_as_f32();
            match weights.get_mut(&name) {
                Some(weight_sum) => {
                    for ((s, ws), v) in sum.iter_mut().zip(weight_sum.iter_mut()).zip(values) {
                        if v < NO_HIT_DEPTH {
                            *s += v as f64 * weight;
                            *ws += weight;
                        }
                    }
                }
                None => {
                    for (s, v) in sum.iter_mut().zip(values) {
                        *s += v as f64 * weight;
                    }
                }
            }
        }
    }
    for (name, weight_sum) in &weights {
        if let Some(sum) = sums.get_mut(name) {
            for (s, ws) in sum.iter_mut().zip(weight_sum) {
                *s = if *ws > 0.0 {
                    *s / ws
                } else {
                    NO_HIT_DEPTH as f64
                };
            }
        }
    }
    normalise_unit_passes(&mut sums, w * h);
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = sums
        .iter()
        .map(|(name, values)| {
            let values = values.iter().map(|&v| v as f32).collect();
            AnyChannel::new(name.as_str(), FlatSamples::F32(values))
        })
        .collect();
    let count = channels.len();
    let mut attributes = LayerAttributes::default();
    attributes.other = headers[0].attributes.clone();
    for (key, value) in samples.metadata() {
        attributes.other.insert(
            Text::from(key.as_str()),
            AttributeValue::Text(Text::from(value.as_str())),
        );
    }
    let layer = Layer::new(
        (w, h),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    write_atomically(output, cancel, |tmp| {
        exr::image::Image::from_layer(layer)
            .write()
            .to_file(tmp)
            .map_err(|e| Error::io(output, std::io::Error::other(e.to_string())))
    })?;
    Ok(MergeSummary {
        width: w,
        height: h,
        channels: count,
        samples,
    })
}

/// Make the normal passes' vectors unit length again (zero stays zero), three channels a pass.
fn normalise_unit_passes(sums: &mut BTreeMap<String, Vec<f64>>, pixels: usize) {
    let mut groups: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for name in sums.keys().filter(|n| rule(n) == Rule::UnitMean) {
        let (pass, _) = name.rsplit_once('.').unwrap_or((name, ""));
        groups
            .entry(pass.to_string())
            .or_default()
            .push(name.clone());
    }
    for names in groups.values() {
        for k in 0..pixels {
            let length = names.iter().map(|n| sums[n][k].powi(2)).sum::<f64>().sqrt();
            if length > 0.0 {
                for n in names {
                    if let Some(v) = sums.get_mut(n) {
                        v[k] /= length;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_join_adjacent_and_refuse_overlaps() {
        let a = SampleRanges::single(3, 0, 4);
        let b = SampleRanges::single(3, 4, 4);
        let ab = a.union(&b).unwrap();
        assert_eq!(ab.ranges, vec![(0, 8)]);
        assert_eq!(ab.count(), 8);
        let gap = ab.union(&SampleRanges::single(3, 16, 8)).unwrap();
        assert_eq!(gap.ranges, vec![(0, 8), (16, 24)]);
        assert_eq!(gap.union(&SampleRanges::single(3, 6, 4)), Err((6, 8)));
        assert_eq!(a.union(&a), Err((0, 4)));
    }

    #[test]
    fn ranges_round_trip_through_the_header_text() {
        let r = SampleRanges {
            seed: 42,
            ranges: vec![(0, 8), (16, 24)],
        };
        let meta: HashMap<String, String> = r.metadata().into_iter().collect();
        assert_eq!(meta[SAMPLES_KEY], "0-8,16-24 seed 42");
        let back = SampleRanges::parse(|k| meta.get(k).cloned()).unwrap();
        assert_eq!(back, Some(r));
        assert_eq!(SampleRanges::parse(|_| None), Ok(None));
        for bad in [
            "4-4 seed 1",
            "x-3 seed 1",
            "0-4,2-6 seed 1",
            "5 seed 1",
            "0-4",
            "0-4 seed x",
        ] {
            let get = |_: &str| Some(bad.to_string());
            assert!(SampleRanges::parse(get).is_err(), "{bad}");
        }
    }

    #[test]
    fn passes_merge_by_their_rules() {
        assert_eq!(rule("ViewLayer.Combined.R"), Rule::Mean);
        assert_eq!(rule("R"), Rule::Mean);
        assert_eq!(rule("ViewLayer.Depth.Z"), Rule::HitMean);
        assert_eq!(rule("ViewLayer.Denoising Normal.X"), Rule::UnitMean);
        assert_eq!(rule("My.Layer.Normal.Y"), Rule::UnitMean);
        assert_eq!(rule("ViewLayer.Denoising Albedo.G"), Rule::Mean);
        assert_eq!(pass_of("ViewLayer.DiffInd.B"), Some("DiffInd"));
    }
}
