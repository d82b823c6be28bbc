//! Volume objects' voxel grids (`PHOTON_object`'s "volume"): the grids a Volume object's
//! material reads, read from its OpenVDB file (`scene::vdb`) within the scene's grid memory
//! limit and attached to the box mesh that stands for the object.

use super::container::Loader;
use super::extensions::VolumeFile;
use crate::error::Result;
use crate::math::{Affine3A, Mat4, Vec3};
use crate::scene::grids::{Grid, MediumExtent, VolumeGrids, MAX_GRID_BYTES};
use crate::scene::vdb;
use std::path::PathBuf;
use std::sync::Arc;

impl Loader {
    /// The grids of `file` that the volume of `material` reads (its node tree's named
    /// attributes), for the mesh of `object`; `None` when it reads none of them.
    pub(super) fn volume_grids(
        &mut self,
        object: &str,
        file: &VolumeFile,
        material: u32,
    ) -> Result<Option<Arc<VolumeGrids>>> {
        let wanted: Vec<String> = self.scene.materials[material as usize]
            .volume
            .as_ref()
            .and_then(|v| v.program.as_ref())
            .map(|p| p.attributes.clone())
            .unwrap_or_default();
        let wanted: Vec<&String> = wanted
            .iter()
            .filter(|n| file.grids.is_empty() || file.grids.contains(n))
            .collect();
        if wanted.is_empty() {
            return Ok(None);
        }
        let mut path = PathBuf::from(&file.uri);
        if path.is_relative() {
            if let Some(base) = &self.base {
                path = base.join(path);
            }
        }
        let in_file = vdb::grid_names(&path).map_err(|e| self.err(object, e.to_string()))?;
        let mut grids = VolumeGrids {
            world_space: file.world_space,
            stochastic: file.stochastic,
            ..VolumeGrids::default()
        };
        // The voxels at or above the clipping value, in the first grid's index space (`None`
        // once a grid of another index space is read: then the whole box holds the medium).
        let mut active: Option<(Mat4, Vec<[i64; 3]>)> = None;
        let mut comparable = true;
        for name in wanted {
            let alias = file.attributes.iter().find(|a| &a.name == name);
            let source = alias.map_or(name, |a| &a.grid);
            if !in_file.iter().any(|(n, _)| n == source) {
                self.scene.warnings.push(format!(
                    "{object}: its OpenVDB file {} has no grid '{source}'",
                    path.display()
                ));
                continue;
            }
            let left = MAX_GRID_BYTES - self.grid_bytes;
            let mut read = vdb::read_grid(&path, source, left).map_err(|e| {
                self.err(
                    object,
                    format!(
                        "{e} (Photon holds at most {} MiB of voxel grids)",
                        MAX_GRID_BYTES >> 20
                    ),
                )
            })?;
            if let Some(alias) = alias {
                read.name = name.clone();
                for v in &mut read.values {
                    let kept = alias.above.is_none_or(|above| *v > above);
                    *v = if kept {
                        alias.offset + alias.scale * *v
                    } else {
                        0.0
                    };
                }
            }
            if let Some(index_to_object) = file.index_to_object {
                read.index_to_local = index_to_object;
            }
            if comparable {
                let (space, list) = active.get_or_insert_with(|| (read.index_to_local, Vec::new()));
                comparable = *space == read.index_to_local;
                let [sx, sy, _] = read.size;
                for (i, value) in read.values.chunks(read.channels).enumerate() {
                    if value.iter().any(|v| v.abs() >= file.clipping) {
                        let local = [i % sx, (i / sx) % sy, i / (sx * sy)];
                        list.push([0, 1, 2].map(|a| read.origin[a] as i64 + local[a] as i64));
                    }
                }
            }
            // Blender 4 puts a voxel's value at the centre of its cell, index + ½; Blender 5 at
            // the index itself.
            // A transform given with the file puts values at the index.
            let at_index = file.values_at_index || file.index_to_object.is_some();
            let offset = if at_index { 0.0 } else { 0.5 };
            let first = Vec3::from(read.origin.map(|i| i as f32 + offset));
            let voxel_to_object = read.index_to_local * Mat4::from_translation(first);
            let grid = Grid::new(
                read.name,
                read.channels,
                read.size,
                read.values,
                voxel_to_object,
            )
            .ok_or_else(|| self.err(object, format!("grid '{name}' has a singular transform")))?;
            self.grid_bytes += grid.bytes();
            grids.grids.push(grid);
        }
        if let (true, Some((index_to_local, voxels))) = (comparable, active) {
            let object_to_index = Affine3A::from_mat4(index_to_local).inverse();
            if object_to_index.is_finite() {
                // No voxel at or above the clipping value: no medium (Cycles builds none).
                grids.extent = Some(
                    MediumExtent::of_voxels(file.extent, object_to_index, voxels.into_iter())
                        .unwrap_or_else(|| MediumExtent::none(object_to_index)),
                );
            }
        }
        Ok((!grids.grids.is_empty()).then(|| Arc::new(grids)))
    }
}
