//! A structure-aware fuzzer for the glTF loader (cargo-fuzz needs a nightly toolchain, which this
//! project does not have): every shipped scene, and a file of `EXT_meshopt_compression` views
//! (`gltf_compression`), is mutated many times, at the JSON level (a value
//! replaced by an extreme or ill-typed one, a key deleted, an array emptied or grown) and at the
//! byte level (binary chunk bytes overwritten, the file truncated), with a deterministic random
//! stream. Each mutant must load to a valid scene or fail with a scene error, never panic; one in
//! eight of the mutants that load is also rendered at 4 × 4 to catch panics downstream.
//!
//! A run mutates every scene `MUTANTS_PER_SCENE` times, mutants numbered from a first one that
//! moves on by that many every day: each run is reproducible within its day, and the runs of
//! successive days cover new mutants rather than repeating the same few. `PHOTON_FUZZ_ITERATIONS`
//! runs more per scene (e.g. for a night), `PHOTON_FUZZ_FIRST` starts at a given mutant (a
//! failure names the one to start at).

use crate::support::gltf;
use crate::support::scenes;

use photon::error::Error;
use photon::render::RenderSettings;
use photon::rng::Rng;
use photon::scene::gltf::{load_slice, LoadOptions};
use serde_json::Value;
use std::path::PathBuf;

/// The shipped scenes, Blender exports included.
fn scene_files() -> Vec<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files = Vec::new();
    for dir in [root.clone(), root.join("blender"), root.join("gallery")] {
        for entry in std::fs::read_dir(dir).expect("scenes folder") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "glb") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// A GLB split into its JSON and binary chunks.
struct Glb {
    json: Value,
    bin: Vec<u8>,
}

fn chunk(bytes: &[u8], at: usize) -> (&[u8], usize) {
    let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    (&bytes[at + 8..at + 8 + len], at + 8 + len)
}

impl Glb {
    fn parse(bytes: &[u8]) -> Glb {
        let (json, next) = chunk(bytes, 12);
        let bin = if next < bytes.len() {
            chunk(bytes, next).0.to_vec()
        } else {
            Vec::new()
        };
        Glb {
            json: serde_json::from_slice(json).expect("shipped scene JSON"),
            bin,
        }
    }

    fn write(&self) -> Vec<u8> {
        gltf::glb(&self.json, &self.bin)
    }
}

/// Values that break naive loaders: negative and huge indices and counts, extreme floats,
/// wrong types.
fn nasty_value(rng: &mut Rng) -> Value {
    let choices = [
        serde_json::json!(-1),
        serde_json::json!(0),
        serde_json::json!(1),
        serde_json::json!(7),
        serde_json::json!(2147483647u64),
        serde_json::json!(4294967295u64),
        serde_json::json!(18446744073709551615u64),
        serde_json::json!(1e38),
        serde_json::json!(-1e38),
        serde_json::json!(1e-38),
        serde_json::json!(0.5),
        serde_json::json!("SCALAR"),
        serde_json::json!(""),
        Value::Null,
        serde_json::json!([]),
        serde_json::json!({}),
        serde_json::json!(true),
        serde_json::json!([1e38, -1e38, 0.0, 1.0]),
    ];
    choices[(rng.uniform() * choices.len() as f32) as usize % choices.len()].clone()
}

/// Every JSON node as a path of keys/indices.
fn paths(v: &Value, prefix: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    out.push(prefix.clone());
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                prefix.push(Value::String(k.clone()));
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(items) => {
            for (i, child) in items.iter().enumerate() {
                prefix.push(Value::from(i));
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

fn node_mut<'a>(mut v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    for key in path {
        v = match key {
            Value::String(k) => v.get_mut(k.as_str()).unwrap(),
            Value::Number(i) => v.get_mut(i.as_u64().unwrap() as usize).unwrap(),
            _ => unreachable!(),
        };
    }
    v
}

/// Apply one random mutation; returns what it did.
fn mutate(glb: &Glb, rng: &mut Rng) -> (Vec<u8>, String) {
    let mut glb = Glb {
        json: glb.json.clone(),
        bin: glb.bin.clone(),
    };
    let pick = |rng: &mut Rng, n: usize| (rng.uniform() * n as f32) as usize % n.max(1);
    let kind = pick(rng, 6);
    let mut all = Vec::new();
    paths(&glb.json, &mut Vec::new(), &mut all);
    let path = all[pick(rng, all.len())].clone();
    let what = match kind {
        0 | 1 => {
            let value = nasty_value(rng);
            let what = format!("{path:?} = {value}");
            *node_mut(&mut glb.json, &path) = value;
            what
        }
        2 => {
            // Delete a key of the node's parent object, or empty an array.
            if let Some((last, parent)) = path.split_last() {
                match (node_mut(&mut glb.json, parent), last) {
                    (Value::Object(map), Value::String(k)) => {
                        map.remove(k);
                    }
                    (Value::Array(items), _) => items.clear(),
                    _ => {}
                }
            }
            format!("delete {path:?}")
        }
        3 => {
            // Grow an array by repeating its items (duplicate nodes, meshes, primitives...).
            if let Value::Array(items) = node_mut(&mut glb.json, &path) {
                let copy = items.clone();
                items.extend(copy);
            }
            format!("duplicate items of {path:?}")
        }
        4 => {
            let n = 1 + pick(rng, 8);
            for _ in 0..n {
                if !glb.bin.is_empty() {
                    let i = pick(rng, glb.bin.len());
                    glb.bin[i] = (rng.uniform() * 256.0) as u8;
                }
            }
            format!("{n} binary bytes overwritten")
        }
        _ => {
            let bytes = glb.write();
            let cut = pick(rng, bytes.len());
            return (bytes[..cut].to_vec(), format!("truncated at {cut}"));
        }
    };
    (glb.write(), what)
}

fn render_tiny(scene: &photon::scene::Scene) {
    let settings = RenderSettings {
        width: 4,
        height: 4,
        spp: 1,
        max_depth: 4,
        ..RenderSettings::default()
    };
    let (image, _) = scenes::render_quietly(scene, &settings).expect("a loaded scene renders");
    assert!(image.rgba.iter().flatten().all(|v| v.is_finite()));
}

/// Mutants of every scene in one run.
const MUTANTS_PER_SCENE: u64 = 40;

fn env_number(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

#[test]
fn mutated_scenes_load_or_fail_cleanly() {
    let iterations = env_number("PHOTON_FUZZ_ITERATIONS").unwrap_or(MUTANTS_PER_SCENE);
    let first = env_number("PHOTON_FUZZ_FIRST").unwrap_or_else(|| {
        let days = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |elapsed| elapsed.as_secs() / 86_400);
        days * MUTANTS_PER_SCENE
    });
    eprintln!(
        "fuzz: mutants {first}..{} of every scene",
        first + iterations
    );
    let (mut loaded, mut refused) = (0u64, 0u64);
    let mut files: Vec<(String, Vec<u8>)> = scene_files()
        .iter()
        .map(|path| {
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            (name, std::fs::read(path).expect("scene file"))
        })
        .collect();
    // Compressed geometry, which no shipped scene has.
    files.push((
        "meshopt.glb".into(),
        crate::gltf_compression::filtered_file(),
    ));
    for (file_index, (name, file)) in files.iter().enumerate() {
        let original = Glb::parse(file);
        for i in first..first + iterations {
            let mut rng = Rng::for_item(0xf022, file_index as u64, i);
            let (bytes, what) = mutate(&original, &mut rng);
            let outcome = std::panic::catch_unwind(|| {
                match load_slice(&bytes, name, &LoadOptions::default()) {
                    Ok(scene) => {
                        assert!(scene.validate().is_ok(), "loaded an invalid scene");
                        if i % 8 == 0 {
                            render_tiny(&scene);
                        }
                        true
                    }
                    Err(Error::Scene { .. }) => false,
                    Err(other) => panic!("not a scene error: {other:?}"),
                }
            });
            match outcome {
                Ok(true) => loaded += 1,
                Ok(false) => refused += 1,
                Err(_) => {
                    let dump = std::env::temp_dir().join(format!("fuzz-{name}-{i}.glb"));
                    std::fs::write(&dump, &bytes).expect("write the failing mutant");
                    panic!(
                        "{name}, mutation {i} ({what}) panicked; mutant in {dump:?} \
                         (PHOTON_FUZZ_FIRST={i} PHOTON_FUZZ_ITERATIONS=1 repeats it)"
                    )
                }
            }
        }
    }
    eprintln!("fuzz: {loaded} mutants loaded, {refused} refused with a scene error");
    assert!(
        loaded > 0 && refused > 0,
        "the mutations must exercise both outcomes"
    );
}
