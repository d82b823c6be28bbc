//! Writing glTF files in memory for the loader's tests: a JSON document and its binary buffer
//! packed as one GLB (the glTF 2.0 binary container: a 12-byte header, a JSON chunk padded with
//! spaces and a BIN chunk padded with zeros, each to four bytes), and `Doc`, a document under
//! construction (accessors, meshes, nodes, cameras) packed that way.

use serde_json::{json, Value};

/// The GLB of `json` with `bin` as its BIN chunk.
pub fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).expect("JSON");
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&text);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}

/// A glTF document under construction with one binary buffer.
pub struct Doc {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Doc {
    pub fn new() -> Doc {
        Doc {
            json: json!({
                "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}],
                "nodes": [], "meshes": [], "accessors": [], "bufferViews": []
            }),
            bin: Vec::new(),
        }
    }

    pub fn push(&mut self, key: &str, item: Value) -> usize {
        let list = self.json[key].as_array_mut().unwrap();
        list.push(item);
        list.len() - 1
    }

    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push(
            "bufferViews",
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
        )
    }

    pub fn floats(&mut self, data: &[f32], kind: &str) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let width = match kind {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 1,
        };
        let view = self.view(&bytes);
        let mut accessor = json!({"bufferView": view, "componentType": 5126, "count": data.len() / width, "type": kind});
        if width == 3 {
            // glTF requires min/max on POSITION; non-finite values are left out of them.
            let bound = |i: usize, f: fn(f32, f32) -> f32, start: f32| {
                data.iter()
                    .skip(i)
                    .step_by(3)
                    .filter(|v| v.is_finite())
                    .fold(start, |a, &b| f(a, b))
            };
            accessor["min"] = json!([0, 1, 2].map(|i| bound(i, f32::min, f32::MAX)));
            accessor["max"] = json!([0, 1, 2].map(|i| bound(i, f32::max, f32::MIN)));
        }
        self.push("accessors", accessor)
    }

    pub fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR"}),
        )
    }

    /// A mesh with one primitive; `normals` may be empty.
    pub fn mesh(
        &mut self,
        name: &str,
        positions: &[f32],
        normals: &[f32],
        indices: &[u32],
    ) -> usize {
        let mut attributes = json!({"POSITION": self.floats(positions, "VEC3")});
        if !normals.is_empty() {
            attributes["NORMAL"] = json!(self.floats(normals, "VEC3"));
        }
        let mut primitive = json!({"attributes": attributes});
        if !indices.is_empty() {
            primitive["indices"] = json!(self.indices(indices));
        }
        self.push("meshes", json!({"name": name, "primitives": [primitive]}))
    }

    /// Add a node; root nodes are listed in the scene.
    pub fn node(&mut self, node: Value, root: bool) -> usize {
        let index = self.push("nodes", node);
        if root {
            self.json["scenes"][0]["nodes"]
                .as_array_mut()
                .unwrap()
                .push(json!(index));
        }
        index
    }

    pub fn camera(&mut self, node_name: &str, camera_name: &str, translation: [f32; 3]) -> usize {
        let list = self.json.as_object_mut().unwrap();
        let cameras = list.entry("cameras").or_insert(json!([]));
        cameras.as_array_mut().unwrap().push(json!({
            "name": camera_name, "type": "perspective",
            "perspective": {"yfov": 0.5, "aspectRatio": 1.5, "znear": 0.1}
        }));
        let index = cameras.as_array().unwrap().len() - 1;
        self.node(
            json!({"name": node_name, "camera": index, "translation": translation}),
            true,
        )
    }

    pub fn finish_json(&self, buffer_uri: Option<&str>) -> Value {
        let mut json = self.json.clone();
        let mut buffer = json!({"byteLength": self.bin.len()});
        if let Some(uri) = buffer_uri {
            buffer["uri"] = json!(uri);
        }
        json["buffers"] = json!([buffer]);
        json
    }

    pub fn glb(&self) -> Vec<u8> {
        glb(&self.finish_json(None), &self.bin)
    }
}

/// A unit right triangle in the XY plane with +Z normals, and a camera.
pub fn triangle_doc() -> Doc {
    let mut doc = Doc::new();
    let mesh = doc.mesh(
        "Tri",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        &[0, 1, 2],
    );
    doc.node(json!({"name": "TriNode", "mesh": mesh}), true);
    doc.camera("Camera", "CameraData", [0.0, 0.0, 5.0]);
    doc
}
