//! Blender's light and shadow linking at render time (Cycles' light sets, after Blender 4.0's
//! Light Linking): the links of the object a ray hit, which the light sampler, the emission a
//! ray meets and the shadow rays read.

use crate::accel::{Hit, NO_INSTANCE};
use crate::scene::{LightLinks, Scene};

/// The light linking of the object `hit` lies on: its mesh's, or the placing instance's.
pub fn hit_links(scene: &Scene, hit: &Hit) -> LightLinks {
    if hit.instance == NO_INSTANCE {
        scene.meshes[hit.mesh as usize].links
    } else {
        scene.instances[hit.instance as usize].links
    }
}

/// Whether `scene` links any light or object.
pub fn scene_is_linked(scene: &Scene) -> bool {
    let none = LightLinks::NONE;
    scene.light_links.iter().any(|l| *l != none)
        || scene.meshes.iter().any(|m| m.links != none)
        || scene.instances.iter().any(|i| i.links != none)
}
