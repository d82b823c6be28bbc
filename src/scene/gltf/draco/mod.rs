//! `KHR_draco_mesh_compression`: triangle meshes compressed with Google's Draco, decoded here in
//! Rust after the Draco bitstream specification 2.2 (Galligan, 2017), with no C++ library.
//! One file per job: `buffer` (bytes, varints, bits), `rans` (entropy coding), `corner_table`,
//! `sequential` and `edgebreaker` (connectivity), `seams` (attributes split where the
//! positions are not), `traversal` (the order values are stored
//! in), `prediction` and `octahedron` (prediction schemes and normal coordinates),
//! `attributes` (integer decoding and dequantization), `decoder` (the whole stream) and
//! `gltf` (the extension: decoded accessors in place of the compressed primitive's).

mod attributes;
mod buffer;
mod corner_table;
mod decoder;
mod edgebreaker;
mod gltf;
mod octahedron;
mod prediction;
mod rans;
mod seams;
mod sequential;
mod traversal;
