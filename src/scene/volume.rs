//! The scene's participating media: what a volume's node tree reads at a point in its object
//! (`Scene::volume_inputs`: coordinates, and a Volume object's grids as named attributes), the
//! coefficients there (`Volume::at`), and the majorants free flights are tracked against — one
//! per medium (`Scene::bound_volumes`) and, for Volume objects, a majorant grid of blocks
//! (`scene::grids::MajorantGrid`).

use super::grids;
use super::{blender_axes, instance_bounds, Affine3A, Bounds, Scene, Vec3, Vec4, Volume};
use crate::medium::Coefficients;
use crate::shader::{NamedAttributes, PointInputs, ShadingInputs, NAMED_ATTRIBUTES};

impl Volume {
    /// A homogeneous medium of coefficients `c`.
    pub fn homogeneous(c: Coefficients) -> Volume {
        Volume {
            constant: Some(c),
            program: None,
            majorant: c.extinction().max_element(),
            emits: c.emission != Vec3::ZERO,
        }
    }

    /// The medium a volume tree describes: homogeneous when the program reads nothing of the
    /// point (evaluated once), else heterogeneous (its majorant set by
    /// `Scene::bound_volumes`); `None` when it is empty (no scattering, absorption or
    /// emission).
    pub fn of(program: crate::shader::NodeProgram) -> Option<Volume> {
        if program.varies() {
            return Some(Volume {
                constant: None,
                program: Some(std::sync::Arc::new(program)),
                majorant: 0.0,
                emits: false,
            });
        }
        Volume::constant(&program)
    }

    /// The homogeneous medium of a program whose result is the same everywhere.
    fn constant(program: &crate::shader::NodeProgram) -> Option<Volume> {
        let at = world_volume_inputs(Vec3::ZERO);
        let c = program.eval_volume(&at, &[]);
        let empty = c.extinction() == Vec3::ZERO && c.emission == Vec3::ZERO;
        (!empty && c.extinction().is_finite() && c.emission.is_finite())
            .then(|| Volume::homogeneous(c))
    }

    /// The medium at world point `p`, inside the object of `mesh` and `instance` (as
    /// `accel::Hit` has them; `None` for the world's volume), at moment `time`; a Volume
    /// object's scaled by `Scene::object_space_density`.
    pub fn at(
        &self,
        scene: &Scene,
        object: Option<(u32, u32)>,
        p: Vec3,
        time: f32,
    ) -> Coefficients {
        if let Some(c) = self.constant {
            return c;
        }
        let Some(program) = &self.program else {
            return Coefficients::VACUUM;
        };
        // Each `ShadingInputs` built where it is kept: a tuple of it would be a copy.
        let inputs;
        let density;
        match object {
            Some((mesh, instance)) => {
                inputs = scene.volume_inputs(mesh, instance, p, time, &program.attributes);
                if !scene.holds_medium(mesh, instance, inputs.points[0].object) {
                    return Coefficients::VACUUM;
                }
                density = scene.object_space_density(mesh, instance, time);
            }
            None => {
                inputs = world_volume_inputs(p);
                density = 1.0;
            }
        }
        let c = program.eval_volume(&inputs, &scene.textures);
        Coefficients {
            scattering: density * c.scattering,
            absorption: density * c.absorption,
            emission: density * c.emission,
            phase: c.phase,
        }
    }
}

impl Volume {
    /// The bound of this medium's extinction along the ray `origin + t dir` (world) at `t`,
    /// inside the object of `object` (as `Volume::at` has it), and where along the ray it
    /// stops holding: a Volume object's majorant grid block by block, else `majorant` for
    /// the whole ray.
    pub fn majorant_along(
        &self,
        scene: &Scene,
        object: Option<(u32, u32)>,
        origin: Vec3,
        dir: Vec3,
        t: f32,
    ) -> (f32, f32) {
        let everywhere = (self.majorant, f32::INFINITY);
        let Some((mesh, instance)) = object else {
            return everywhere;
        };
        let placed = scene.instances.get(instance as usize);
        let stored = match placed {
            Some(inst) => &scene.prototypes[inst.prototype as usize],
            None => &scene.meshes[mesh as usize],
        };
        let (Some(grids), Some(space)) = (&stored.volume_grids, &stored.object_space) else {
            return everywhere;
        };
        let Some(majorant) = &grids.majorant else {
            return everywhere;
        };
        let to_object = match placed {
            Some(inst) => space.to_object * inst.to_object_at(0.5),
            None => space.to_object,
        };
        let (bound, end) = majorant.along(
            to_object.transform_point3(origin),
            to_object.transform_vector3(dir),
            t,
        );
        let density = if grids.world_space {
            1.0
        } else {
            object_space_density(to_object)
        };
        (bound * density, end)
    }
}

/// How many times denser per unit of world length a Volume object's medium is than its tree
/// says, given its world → object map `to_object`: Blender's volume space "Object" (the
/// default) keeps a Volume object's density per unit of the object's own length, so that it
/// looks the same at any scale. Non-uniform scales count by their geometric mean.
fn object_space_density(to_object: Affine3A) -> f32 {
    let density = to_object.matrix3.determinant().abs().cbrt();
    if density.is_finite() && density > 0.0 {
        density
    } else {
        1.0
    }
}

/// The `named` attributes a volume tree reads, of those `grids` has: `value` of each.
fn grid_attributes(
    grids: &grids::VolumeGrids,
    named: &[String],
    mut value: impl FnMut(&grids::Grid) -> Vec4,
) -> NamedAttributes {
    let mut out = NamedAttributes::default();
    for (k, name) in named.iter().enumerate().take(NAMED_ATTRIBUTES) {
        if let Some(grid) = grids.get(name) {
            out.values[k] = value(grid);
            out.found |= 1 << k;
        }
    }
    out
}

/// Three numbers in [0, 1) drawn from the bits of point `p` and `lookup`: the point of a
/// medium is itself random (a free flight's or a step's), so its bits serve as the random
/// numbers of a stochastic grid lookup there, a different triple for each lookup.
fn point_random(p: Vec3, lookup: u32) -> Vec3 {
    let bits = [p.x, p.y, p.z].map(|c| u64::from(c.to_bits()));
    let h = crate::rng::hash_combine(&[bits[0], bits[1], bits[2], u64::from(lookup)]);
    let unit = |k: u32| ((h >> (21 * k)) & 0x1f_ffff) as f32 * (1.0 / (1u32 << 21) as f32);
    Vec3::new(unit(0), unit(1), unit(2))
}

/// What the world's volume tree reads at world point `p`: the position, which its Object and
/// Generated coordinates also are.
fn world_volume_inputs(p: Vec3) -> ShadingInputs {
    let at = blender_axes(p);
    ShadingInputs::at_point(PointInputs {
        position: at,
        object: at,
        generated: at,
        color: Vec4::ONE,
        ..PointInputs::default()
    })
}

impl Scene {
    /// What a volume's node tree reads at world point `p` inside the object of `mesh` (an
    /// index into `meshes`, or into `prototypes` placed by `instance`, as `accel::Hit` has
    /// them) at moment `time`: the position, and the Object and Generated coordinates of the
    /// object's texture space (what Cycles' volume shading points read), and the `named`
    /// attributes the object's grids have, sampled at the point.
    #[allow(clippy::field_reassign_with_default)] // a literal with `..default()` copies more
    pub fn volume_inputs(
        &self,
        mesh: u32,
        instance: u32,
        p: Vec3,
        time: f32,
        named: &[String],
    ) -> ShadingInputs {
        let placed = self.instances.get(instance as usize);
        let (mesh, stored) = match placed {
            Some(inst) => (
                &self.prototypes[inst.prototype as usize],
                inst.to_object_at(time).transform_point3(p),
            ),
            None => (&self.meshes[mesh as usize], p),
        };
        let mut point = PointInputs {
            position: blender_axes(p),
            color: Vec4::ONE,
            ..PointInputs::default()
        };
        (point.object, point.generated) = match &mesh.object_space {
            Some(space) => {
                let o = space.to_object.transform_point3(stored);
                (o, space.generated(o))
            }
            None => (blender_axes(p), blender_axes(p)),
        };
        // As `ShadingInputs::at_point`, built in place (its result moved here was a copy).
        let mut inputs = ShadingInputs::default();
        inputs.points = [point; 3];
        if let Some(grids) = &mesh.volume_grids {
            inputs.attributes = if grids.stochastic {
                let mut lookup = 0u32;
                grid_attributes(grids, named, |g| {
                    lookup += 1;
                    g.sample_one_voxel(point.object, point_random(point.object, lookup))
                })
            } else {
                grid_attributes(grids, named, |g| g.sample(point.object))
            };
        }
        inputs
    }

    /// Whether object point `object_point` of the object of `mesh` and `instance` (as
    /// `volume_inputs` has them) holds its medium: inside a Volume object's extent
    /// (`grids::MediumExtent`), anywhere in other objects.
    fn holds_medium(&self, mesh: u32, instance: u32, object_point: Vec3) -> bool {
        let stored = match self.instances.get(instance as usize) {
            Some(inst) => &self.prototypes[inst.prototype as usize],
            None => &self.meshes[mesh as usize],
        };
        stored
            .volume_grids
            .as_ref()
            .and_then(|g| g.extent.as_ref())
            .is_none_or(|extent| extent.contains(object_point))
    }

    /// How many times denser per unit of world length the medium inside the object of `mesh`
    /// and `instance` (as `accel::Hit` has them) is than its tree says at moment `time`: a
    /// Volume object's (one with voxel grids) by its scale (`object_space_density`), 1 for
    /// other objects and for Volume objects whose density is per unit of world length.
    pub fn object_space_density(&self, mesh: u32, instance: u32, time: f32) -> f32 {
        let placed = self.instances.get(instance as usize);
        let stored = match placed {
            Some(inst) => &self.prototypes[inst.prototype as usize],
            None => &self.meshes[mesh as usize],
        };
        let (Some(grids), Some(space)) = (&stored.volume_grids, &stored.object_space) else {
            return 1.0;
        };
        if grids.world_space {
            return 1.0;
        }
        object_space_density(match placed {
            Some(inst) => space.to_object * inst.to_object_at(time),
            None => space.to_object,
        })
    }

    /// Sets the majorant of every heterogeneous volume: the largest extinction coefficient of
    /// its program at points spread over the bounds of the objects it fills (a jittered 12³
    /// lattice in each of at most 64 boxes; the world's over the scene's bounds), times 1.5
    /// for what the lattice misses. Where a point's extinction still exceeds it, free flights
    /// clamp their null collisions (`crate::medium`), a small bias.
    pub fn bound_volumes(&mut self) {
        self.settle_volumes_without_grids();
        const SIDE: usize = 12;
        const MAX_BOXES: usize = 64;
        let mut boxes: Vec<Vec<(u32, u32, Bounds)>> = vec![Vec::new(); self.materials.len()];
        for (k, mesh) in self.meshes.iter().enumerate() {
            if let Some(list) = boxes.get_mut(mesh.material as usize) {
                list.push((k as u32, u32::MAX, mesh.bounds()));
            }
        }
        let local: Vec<Bounds> = self.prototypes.iter().map(|m| m.bounds()).collect();
        for (i, instance) in self.instances.iter().enumerate() {
            let prototype = instance.prototype as usize;
            let material = self.prototypes[prototype].material as usize;
            if let Some(list) = boxes.get_mut(material) {
                let b = instance_bounds(instance, local[prototype]);
                list.push((prototype as u32, i as u32, b));
            }
        }
        let bound = |scene: &Scene, volume: &Volume, places: &[(Option<(u32, u32)>, Bounds)]| {
            let mut most = 0.0f32;
            let mut emits = false;
            for (object, b) in places.iter().take(MAX_BOXES) {
                if b.is_empty() {
                    continue;
                }
                for i in 0..SIDE * SIDE * SIDE {
                    let cell = Vec3::new(
                        (i % SIDE) as f32,
                        ((i / SIDE) % SIDE) as f32,
                        (i / (SIDE * SIDE)) as f32,
                    );
                    // A fixed jitter per cell (a golden-ratio sequence): reproducible.
                    let j = (i as f32 * 0.618_034).fract();
                    let f = (cell + Vec3::new(j, (j * 1.618).fract(), (j * 2.618).fract()))
                        / SIDE as f32;
                    let p = b.min + (b.max - b.min) * f;
                    let c = volume.at(scene, *object, p, 0.5);
                    let sigma = c.extinction().max_element();
                    if sigma.is_finite() {
                        most = most.max(sigma);
                    }
                    emits |= c.emission.max_element() > 0.0;
                }
            }
            (1.5 * most, emits)
        };
        // Volume objects' majorant grids, their largest value a floor of the material's.
        let mut grid_most = vec![0.0f32; self.materials.len()];
        let mut grid_emits = vec![false; self.materials.len()];
        for (m, list) in boxes.iter().enumerate() {
            let Some(volume) = self.materials[m].volume.as_ref() else {
                continue;
            };
            for &(mesh, instance, _) in list {
                let stored = match self.instances.get(instance as usize) {
                    Some(inst) => &self.prototypes[inst.prototype as usize],
                    None => &self.meshes[mesh as usize],
                };
                let bounded = stored
                    .volume_grids
                    .as_ref()
                    .is_some_and(|g| g.majorant.is_some());
                if bounded {
                    continue;
                }
                let Some((majorant, emits)) = self.grid_majorant(volume, mesh, instance) else {
                    continue;
                };
                grid_emits[m] |= emits;
                let most = majorant.values.iter().fold(0.0f32, |a, &b| a.max(b));
                let density = self.object_space_density(mesh, instance, 0.5);
                grid_most[m] = grid_most[m].max(most * density);
                let stored = match self.instances.get(instance as usize) {
                    Some(inst) => &mut self.prototypes[inst.prototype as usize],
                    None => &mut self.meshes[mesh as usize],
                };
                // Shared grids (a file read for two objects) keep the scalar majorant.
                if let Some(grids) = stored
                    .volume_grids
                    .as_mut()
                    .and_then(std::sync::Arc::get_mut)
                {
                    grids.majorant = Some(majorant);
                }
            }
        }
        for (m, list) in boxes.iter().enumerate() {
            let Some(volume) = self.materials[m]
                .volume
                .as_ref()
                .filter(|v| v.constant.is_none())
            else {
                continue;
            };
            let places: Vec<_> = list
                .iter()
                .map(|&(mesh, instance, b)| (Some((mesh, instance)), b))
                .collect();
            let (majorant, emits) = bound(self, volume, &places);
            if let Some(v) = self.materials[m].volume.as_mut() {
                v.majorant = majorant.max(grid_most[m]);
                v.emits = emits || grid_emits[m];
            }
        }
        if let Some(volume) = self.world.volume.as_ref().filter(|v| v.constant.is_none()) {
            let (majorant, emits) = bound(self, volume, &[(None, self.bounds())]);
            if let Some(v) = self.world.volume.as_mut() {
                (v.majorant, v.emits) = (majorant, emits);
            }
        }
    }

    /// Makes homogeneous the volumes that vary only by the named attributes Principled Volume
    /// reads (its Density Attribute is "density" by default) when no object of their material
    /// has grids: the attributes are never found there, so the medium is the same everywhere
    /// and is integrated exactly instead of tracked.
    fn settle_volumes_without_grids(&mut self) {
        let mut with_grids = vec![false; self.materials.len()];
        for mesh in self.meshes.iter().chain(&self.prototypes) {
            if let (Some(slot), Some(_)) = (
                with_grids.get_mut(mesh.material as usize),
                &mesh.volume_grids,
            ) {
                *slot = true;
            }
        }
        for (material, has_grids) in self.materials.iter_mut().zip(with_grids) {
            let Some(program) = material.volume.as_ref().and_then(|v| v.program.as_ref()) else {
                continue;
            };
            if !has_grids && !program.varies_without_named_attributes() {
                material.volume = Volume::constant(program);
            }
        }
    }

    /// The bound of `volume`'s extinction inside the object of `mesh` and `instance` that its
    /// voxel grids give, block by block of the first grid its tree reads (`MajorantGrid`):
    /// the tree evaluated at each block's centre and corners with every grid's largest value
    /// touching the block, which bounds the trees that grow with their attributes (density ×
    /// Density, the usual), times 1.5 for the rest, and whether the tree emitted light at any
    /// of those points; `None` without grids. Its values are per unit of the object's own
    /// length: `Volume::majorant_along` scales them as `Volume::at` scales the medium.
    fn grid_majorant(
        &self,
        volume: &Volume,
        mesh: u32,
        instance: u32,
    ) -> Option<(grids::MajorantGrid, bool)> {
        let program = volume.program.as_ref()?;
        let placed = self.instances.get(instance as usize);
        let stored = match placed {
            Some(inst) => &self.prototypes[inst.prototype as usize],
            None => &self.meshes[mesh as usize],
        };
        let (grids, space) = (stored.volume_grids.as_ref()?, stored.object_space.as_ref()?);
        let first = program.attributes.iter().find_map(|n| grids.get(n))?;
        // Object point → world point.
        let to_stored = space.to_object.inverse();
        let to_world = placed.map_or(Affine3A::IDENTITY, |inst| inst.to_world_at(0.5));
        const BLOCKS: usize = 32;
        let edge = first.size.map(|s| s.div_ceil(BLOCKS).max(4));
        let blocks = [0, 1, 2].map(|a| first.size[a].div_ceil(edge[a]));
        let mut values = Vec::with_capacity(blocks.iter().product());
        let mut emits = false;
        for bz in 0..blocks[2] {
            for by in 0..blocks[1] {
                for bx in 0..blocks[0] {
                    let lo = Vec3::new(
                        (bx * edge[0]) as f32,
                        (by * edge[1]) as f32,
                        (bz * edge[2]) as f32,
                    );
                    let hi = lo + Vec3::new(edge[0] as f32, edge[1] as f32, edge[2] as f32);
                    let attributes = grid_attributes(grids, &program.attributes, |g| {
                        let (glo, ghi) = g.voxel_box_of(first, lo, hi);
                        g.max_over(glo, ghi).extend(1.0)
                    });
                    let mut most = 0.0f32;
                    for corner in 0..9 {
                        let pick = |bit: usize, a: f32, b: f32| match corner {
                            8 => 0.5 * (a + b),
                            _ if corner >> bit & 1 == 0 => a,
                            _ => b,
                        };
                        let v = Vec3::new(
                            pick(0, lo.x, hi.x),
                            pick(1, lo.y, hi.y),
                            pick(2, lo.z, hi.z),
                        );
                        let o = first.object_point(v);
                        let p = to_world.transform_point3(to_stored.transform_point3(o));
                        let mut inputs =
                            self.volume_inputs(mesh, instance, p, 0.5, &program.attributes);
                        inputs.attributes = attributes;
                        let c = program.eval_volume(&inputs, &self.textures);
                        let sigma = c.extinction().max_element();
                        if sigma.is_finite() {
                            most = most.max(sigma);
                        }
                        emits |= c.emission.max_element() > 0.0;
                    }
                    values.push(1.5 * most);
                }
            }
        }
        let grid = grids::MajorantGrid {
            blocks,
            edge,
            values,
            object_to_voxel: first.object_to_voxel(),
        };
        Some((grid, emits))
    }

    /// The world or some material has a volume (participating media).
    pub fn has_media(&self) -> bool {
        self.world.volume.is_some() || self.materials.iter().any(|m| m.volume.is_some())
    }

    /// The world or some material has a volume that emits light.
    pub fn media_emit(&self) -> bool {
        let volumes = self.materials.iter().map(|m| &m.volume);
        std::iter::once(&self.world.volume)
            .chain(volumes)
            .any(|v| v.as_ref().is_some_and(|v| v.emits))
    }
}
