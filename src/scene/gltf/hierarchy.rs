//! The node hierarchy: its size counted against Photon's limits before any geometry is read or
//! allocated (node instances, triangles, vertices; cycles and depth refused), which meshes are
//! stored once as prototypes and placed by instances, and the walk that places meshes,
//! cameras and lights in world space, carrying moving parents' poses to their children.

use super::camera::{node_camera, FoundCamera};
use super::container::{named, Loader};
use super::extensions::NodeExtensions;
use crate::error::Result;
use crate::math::{Affine3A, Mat3, Mat4};
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::rc::Rc;

/// Scenes with more triangles than this (after instancing) are refused rather than exhausting
/// memory.
pub const MAX_TRIANGLES: usize = 200_000_000;

/// Node instances (nodes reached through the hierarchy, counting each path to a shared node)
/// beyond this are refused: a small file can otherwise describe billions of instances.
pub const MAX_NODE_INSTANCES: usize = 1_000_000;

/// Vertices (after instancing) beyond this are refused.
pub const MAX_VERTICES: usize = 400_000_000;

/// Node hierarchies deeper than this are treated as broken.
pub(super) const MAX_NODE_DEPTH: usize = 1000;

/// Where a node's parent is: its world matrix, and its poses over the shutter when it moves
/// (empty: still).
pub(super) struct Placement {
    pub(super) world: Mat4,
    pub(super) motion: Vec<Affine3A>,
}

impl Placement {
    pub(super) const ROOT: Placement = Placement {
        world: Mat4::IDENTITY,
        motion: Vec::new(),
    };
}

impl Loader {
    /// Count what the scene's hierarchy instantiates (node instances, and triangles and
    /// vertices from the accessors' counts) and refuse it when it is over a limit, before any
    /// geometry is read or allocated.
    pub(super) fn check_sizes(&mut self, gltf_scene: &gltf::Scene) -> Result<()> {
        let mut per_mesh: HashMap<usize, (usize, usize)> = HashMap::new();
        for mesh in self.document.meshes() {
            let (mut triangles, mut vertices) = (0usize, 0usize);
            for primitive in mesh.primitives() {
                let Some(positions) = primitive.get(&gltf::Semantic::Positions) else {
                    continue;
                };
                self.check_accessor_fits(&positions)?;
                if let Some(indices) = primitive.indices() {
                    self.check_accessor_fits(&indices)?;
                }
                let count = primitive.indices().map_or(positions.count(), |a| a.count());
                triangles = triangles.saturating_add(match primitive.mode() {
                    Mode::Triangles => count / 3,
                    Mode::TriangleStrip | Mode::TriangleFan => count.saturating_sub(2),
                    _ => 0,
                });
                vertices = vertices.saturating_add(positions.count());
            }
            per_mesh.insert(mesh.index(), (triangles, vertices));
        }
        // Meshes placed by two or more nodes become prototypes: stored once, placed by
        // instances.
        // So do meshes of nodes that move while the shutter is open (or whose ancestors do): an
        // instance is placed per ray, at the ray's moment.
        let mut uses: HashMap<usize, usize> = HashMap::new();
        let mut moving = std::collections::HashSet::new();
        let mut visited = 0;
        for node in gltf_scene.nodes() {
            count_mesh_uses(
                &node,
                &self.node_extensions,
                &mut uses,
                &mut moving,
                false,
                0,
                &mut visited,
            );
        }
        self.instanced_meshes = uses
            .into_iter()
            .filter(|&(mesh, n)| n >= 2 || moving.contains(&mesh))
            .map(|(mesh, _)| mesh)
            .collect();
        let mut totals = SizeTotals::default();
        for node in gltf_scene.nodes() {
            self.count_node(&node, &per_mesh, &mut Vec::new(), &mut totals)?;
        }
        Ok(())
    }

    /// Whether `node` places its mesh as an instance: an instanced mesh and a transform that
    /// is invertible and, unless the node `moving`, not mirrored (still mirrored copies are
    /// flattened, moving ones are mirrored instances).
    pub(super) fn places_instance(&self, node: &gltf::Node, world: &Mat4, moving: bool) -> bool {
        let Some(mesh) = node.mesh() else {
            return false;
        };
        // Skinned and morphed copies have vertices of their own.
        let own_vertices = node.skin().is_some()
            || node.weights().is_some()
            || self
                .pose
                .get(&node.index())
                .is_some_and(|p| p.weights.is_some());
        let det = Mat3::from_mat4(*world).determinant();
        !own_vertices
            && self.instanced_meshes.contains(&mesh.index())
            && det.is_finite()
            && (det > 0.0 || (moving && det < 0.0))
    }

    /// Refuse the node `object` when it is its own ancestor, lies `depth` nodes deep, past
    /// `MAX_NODE_DEPTH`, or is node instance number `instances`, past `MAX_NODE_INSTANCES`.
    fn check_node(
        &self,
        object: &str,
        is_own_ancestor: bool,
        depth: usize,
        instances: usize,
    ) -> Result<()> {
        if is_own_ancestor {
            return Err(self.err(object, "is its own ancestor (cycle in the node hierarchy)"));
        }
        if depth >= MAX_NODE_DEPTH {
            return Err(self.err(
                object,
                format!("node hierarchy deeper than {MAX_NODE_DEPTH}"),
            ));
        }
        if instances > MAX_NODE_INSTANCES {
            return Err(self.err(
                object,
                format!("the hierarchy instances more than {MAX_NODE_INSTANCES} nodes"),
            ));
        }
        Ok(())
    }

    pub(super) fn count_node(
        &self,
        node: &gltf::Node,
        per_mesh: &HashMap<usize, (usize, usize)>,
        ancestors: &mut Vec<(usize, Mat4)>,
        totals: &mut SizeTotals,
    ) -> Result<()> {
        let parent = ancestors.last().map_or(Mat4::IDENTITY, |a| a.1);
        let world = parent * self.local_matrix(node);
        let object = named("node", node.index(), node.name());
        let is_own_ancestor = ancestors.iter().any(|a| a.0 == node.index());
        totals.instances += 1;
        self.check_node(&object, is_own_ancestor, ancestors.len(), totals.instances)?;
        let gpu_instances = match node.mesh() {
            Some(_) => self.gpu_instance_count(node)?,
            None => None,
        };
        if let Some(count) = gpu_instances {
            totals.instances = totals.instances.saturating_add(count);
            self.check_node(&object, false, ancestors.len(), totals.instances)?;
        }
        if let Some(mesh) = node.mesh() {
            let (mut triangles, mut vertices) =
                per_mesh.get(&mesh.index()).copied().unwrap_or_default();
            // Moving mirrored nodes are counted as flattened: an upper bound. GPU instances
            // are all instances of one prototype.
            if gpu_instances.is_some()
                || world.is_finite() && self.places_instance(node, &world, false)
            {
                // Stored once, however many instances place it.
                if !totals.counted_prototypes.insert(mesh.index()) {
                    (triangles, vertices) = (0, 0);
                }
            }
            totals.triangles = totals.triangles.saturating_add(triangles);
            totals.vertices = totals.vertices.saturating_add(vertices);
            if totals.triangles > MAX_TRIANGLES {
                return Err(self.err(
                    object,
                    format!(
                        "the scene instances more than Photon's limit of {MAX_TRIANGLES} \
                         triangles (refused before loading any geometry)"
                    ),
                ));
            }
            if totals.vertices > MAX_VERTICES {
                return Err(self.err(
                    object,
                    format!(
                        "the scene instances more than Photon's limit of {MAX_VERTICES} \
                         vertices (refused before loading any geometry)"
                    ),
                ));
            }
        }
        ancestors.push((node.index(), world));
        for child in node.children() {
            self.count_node(&child, per_mesh, ancestors, totals)?;
        }
        ancestors.pop();
        Ok(())
    }

    pub(super) fn visit_node(
        &mut self,
        node: &gltf::Node,
        parent: Placement,
        ancestors: &mut Vec<usize>,
        cameras: &mut Vec<FoundCamera>,
    ) -> Result<()> {
        let object = named("node", node.index(), node.name());
        self.node_instances += 1;
        let is_own_ancestor = ancestors.contains(&node.index());
        self.check_node(
            &object,
            is_own_ancestor,
            ancestors.len(),
            self.node_instances,
        )?;
        let local = self.local_matrix(node);
        let world = parent.world * local;
        if !world.is_finite() {
            return Err(self.err(object, "transform is NaN or infinite"));
        }
        // Its own poses over the shutter (world matrices), or its moving parent's carrying it.
        let extensions = Rc::clone(&self.node_extensions);
        let own = &extensions[node.index()];
        let motion = if own.object.motion.is_empty() {
            parent
                .motion
                .iter()
                .map(|pose| *pose * Affine3A::from_mat4(local))
                .collect()
        } else {
            own.object.motion.clone()
        };
        if let Some(mesh) = node.mesh() {
            if let Some(transforms) = self.gpu_instances(node)? {
                self.add_gpu_instances(node, &mesh, &world, &transforms)?;
            } else if self.places_instance(node, &world, !motion.is_empty()) {
                self.add_instance(node, &mesh, &world, &motion)?;
            } else {
                if !motion.is_empty() || own.object.moves() {
                    self.scene.warnings.push(format!(
                        "{object}: motion blur is not rendered for it (a singular transform: \
                         only invertible ones are placed per moment)"
                    ));
                }
                self.add_mesh(node, &mesh, &world, false)?;
            }
        }
        let camera = node_camera(node, &world, own.camera.as_ref())
            .map_err(|(object, message)| self.err(object, message))?;
        cameras.extend(camera);
        self.add_lights(node, &world, own.light.as_ref())?;
        ancestors.push(node.index());
        for child in node.children() {
            let placement = Placement {
                world,
                motion: motion.clone(),
            };
            self.visit_node(&child, placement, ancestors, cameras)?;
        }
        ancestors.pop();
        Ok(())
    }
}

/// How many node instances place each mesh, and which meshes move while the shutter is open
/// (placed by a node with a `motion` or under one). Stops after `MAX_NODE_INSTANCES` nodes or at
/// `MAX_NODE_DEPTH` (cycles and depth are refused by `Loader::count_node`, which walks the same
/// hierarchy next).
pub(super) fn count_mesh_uses(
    node: &gltf::Node,
    extensions: &[NodeExtensions],
    uses: &mut HashMap<usize, usize>,
    moving: &mut std::collections::HashSet<usize>,
    moving_above: bool,
    depth: usize,
    visited: &mut usize,
) {
    *visited += 1;
    if depth >= MAX_NODE_DEPTH || *visited > MAX_NODE_INSTANCES {
        return;
    }
    let moves = moving_above || extensions[node.index()].object.moves();
    if let Some(mesh) = node.mesh() {
        // A node with EXT_mesh_gpu_instancing places its mesh many times: a prototype.
        let gpu_instanced = node.extension_value("EXT_mesh_gpu_instancing").is_some();
        *uses.entry(mesh.index()).or_default() += if gpu_instanced { 2 } else { 1 };
        if moves {
            moving.insert(mesh.index());
        }
    }
    for child in node.children() {
        count_mesh_uses(&child, extensions, uses, moving, moves, depth + 1, visited);
    }
}

/// Running totals of `Loader::check_sizes`.
#[derive(Default)]
pub(super) struct SizeTotals {
    instances: usize,
    triangles: usize,
    vertices: usize,
    /// Instanced meshes whose triangles are counted already.
    counted_prototypes: std::collections::HashSet<usize>,
}
