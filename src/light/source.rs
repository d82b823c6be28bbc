//! What a light is to the integrators: one emitter of the scene (`LightSource`), a direction
//! sampled towards one (`LightSample`), and the point a sample is drawn from (`Receiver`).

use crate::interaction::LightPoint;
use crate::math::Vec3;
use crate::scene::Lamp;

/// One emitter.
#[derive(Clone, Debug)]
pub enum LightSource {
    /// A triangle of a mesh whose material emits; radiance comes from the material at the point.
    Triangle {
        mesh: u32,
        triangle: u32,
        area: f32,
        two_sided: bool,
    },
    /// An instance of a prototype whose material emits (`Scene::instances`): one of its
    /// triangles, picked by `Lights::prototype_triangles`, where the instance is at the
    /// sample's moment. `area` is its world area when still (for its share of samples).
    Instance {
        instance: u32,
        area: f32,
        two_sided: bool,
    },
    /// `radius` > 0 makes it a lamp of uniform radiance I / (πr²) as Cycles makes Blender's
    /// point light: a disc of that radius facing the viewer (Soft Falloff) or a sphere
    /// (`lamp_cone`); the same intensity far away, soft shadows near it, and seen by the rays
    /// `lamp` names (`Lights::lamps_met`).
    Point {
        position: Vec3,
        intensity: Vec3,
        radius: f32,
        lamp: Lamp,
    },
    /// A spot: a point light (or lamp, as `Point`) within the cone `cos_outer`..`cos_inner`
    /// around `direction`, evaluated along each ray that leaves the lamp.
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
        radius: f32,
        lamp: Lamp,
    },
    /// A sun: `to_sun` points from the scene towards the sun; a cone of half-angle θ with
    /// cos θ = `cos_max` (1 for a hard sun, which is then a delta light).
    Sun {
        to_sun: Vec3,
        irradiance: Vec3,
        cos_max: f32,
    },
    /// The world background; `radiance` is its average over the sphere (the constant colour,
    /// or the environment map's mean), which sets its share of light and photon samples.
    World { radiance: Vec3 },
}

/// A sampled direction towards a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving along `wi` (for delta lights: intensity / d² or irradiance), before
    /// dividing by `pdf`.
    pub li: Vec3,
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Density per unit solid angle, including the probability of choosing this light; for delta
    /// lights only that probability.
    pub pdf: f32,
    /// The light cannot be reached by BSDF-sampled rays (a point, a hard sun, a lamp hidden
    /// from scattered rays or so far that it is a point): its sample is used without MIS.
    pub delta: bool,
    /// Where the shadow ray must reach.
    pub target: LightPoint,
    /// The light's blocker set (Blender's shadow linking): only objects in it cast its
    /// shadows; 0: every object.
    pub blockers: u8,
}

/// Where a light sample is drawn from: the point and, on an opaque surface, its geometric
/// normal turned to the viewer, below whose plane no light reaches what the surface scatters
/// (`LocalSelection` then leaves out the lights wholly below it).
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub p: Vec3,
    pub horizon: Option<Vec3>,
    /// The receiver sets of the object the point lies on (`LightLinks::lit_by`): lights
    /// linked to other sets do not light it.
    pub lit_by: u64,
}

impl Receiver {
    /// A point that may be lit from every direction, by every light.
    pub fn at(p: Vec3) -> Receiver {
        Receiver {
            p,
            horizon: None,
            lit_by: u64::MAX,
        }
    }
}
