//! The media a ray travels in: the world's volume and the volumes of the objects whose surface
//! it crossed into, kept as a small stack as Cycles keeps its volume stack. A ray enters an
//! object's medium when it crosses the surface against its winding (from the front) and
//! leaves it when it crosses back; media that overlap add (`medium::Coefficients::add`).
//!
//! Crossings happen where a path or a shadow ray passes a surface: through a transmissive
//! BSDF, or through the invisible boundary of an object that has a volume and no surface
//! shader (a white Transparent BSDF, as Cycles passes volume-only surfaces).

use super::Context;
use crate::accel::{Hit, Ray, Visibility, FRAME_TIME};
use crate::interaction::SurfaceHit;
use crate::math::Vec3;
use crate::medium::{Coefficients, Media};
use crate::scene::{Scene, Volume};

/// Object media a stack holds at most (deeper nesting is ignored: the innermost are dropped).
const DEPTH: usize = 8;

/// One object's medium the ray is in: its material and the mesh (and instance) whose surface
/// it entered by (`accel::Hit`'s indices), where heterogeneous media read their coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry {
    material: u32,
    mesh: u32,
    instance: u32,
}

impl Entry {
    /// Whether this is the medium of `material` in the object whose surface `hit` is on (the
    /// instance too: copies of one prototype may overlap).
    fn is_of(&self, material: u32, hit: &Hit) -> bool {
        self.material == material && self.mesh == hit.mesh && self.instance == hit.instance
    }
}

/// The object media a ray is in (the world's volume is under all of them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MediumStack {
    entries: [Option<Entry>; DEPTH],
}

impl MediumStack {
    /// Whether a ray with this stack travels through any medium in `scene`.
    pub fn is_vacuum(&self, scene: &Scene) -> bool {
        scene.world.volume.is_none() && self.entries[0].is_none()
    }

    /// The media at point `p` (at moment `time`), found as Cycles initialises its volume
    /// stack: a ray from `p` crosses every surface out to the scene's edge, and each object
    /// it leaves without having entered it on the way holds `p`. Empty (only the world's
    /// volume) when no material has a volume.
    pub fn at(ctx: &Context, p: Vec3, time: f32) -> MediumStack {
        let scene = ctx.scene;
        let mut stack = MediumStack::default();
        if !scene.materials.iter().any(|m| m.volume.is_some()) {
            return stack;
        }
        // Objects entered along the probe (their leaving then says nothing about `p`).
        let mut entered = MediumStack::default();
        // An direction unlikely to graze axis-aligned walls.
        let dir = Vec3::new(0.267_261_24, 0.534_522_5, 0.801_783_7);
        let mut ray = Ray {
            origin: p,
            direction: dir,
            t_max: f32::INFINITY,
            time,
        };
        for _ in 0..64 {
            let Some(hit) = ctx.accel.intersect(scene, &ray, Visibility::Secondary) else {
                break;
            };
            let sh = SurfaceHit::new(scene, &ray, &hit);
            let entering = dir.dot(sh.ng) < 0.0;
            if scene.materials[sh.material as usize].volume.is_some() {
                let key = |e: &Entry| e.is_of(sh.material, &hit);
                if entering {
                    entered = entered.crossed(scene, &hit, sh.material, true);
                } else if entered.entries.iter().flatten().any(key) {
                    entered = entered.crossed(scene, &hit, sh.material, false);
                } else {
                    stack = stack.crossed(scene, &hit, sh.material, true);
                }
            }
            ray = sh.spawn(dir);
        }
        stack
    }

    /// Whether the ray is in the medium of `material` entered by the surface of `mesh` and
    /// `instance` (as `accel::Hit` names them).
    pub fn holds(&self, material: u32, mesh: u32, instance: u32) -> bool {
        let entry = Entry {
            material,
            mesh,
            instance,
        };
        self.entries.iter().map_while(|e| *e).any(|e| e == entry)
    }

    /// The stack after crossing the surface of `hit` (of material `material`): `entering`
    /// when the ray goes against the surface's winding normal (into the object).
    pub fn crossed(&self, scene: &Scene, hit: &Hit, material: u32, entering: bool) -> MediumStack {
        if scene.materials[material as usize].volume.is_none() {
            return *self;
        }
        let entry = Entry {
            material,
            mesh: hit.mesh,
            instance: hit.instance,
        };
        let mut out = *self;
        if entering {
            // Entered again without leaving (a boundary face coplanar with another object's,
            // which the ray passed as one): held once, as Cycles' volume stack holds an object.
            if out.entries.iter().flatten().any(|e| *e == entry) {
                return out;
            }
            if let Some(slot) = out.entries.iter_mut().find(|e| e.is_none()) {
                *slot = Some(entry);
            }
        } else if let Some(k) = out
            .entries
            .iter()
            .position(|e| e.is_some_and(|e| e.is_of(material, hit)))
        {
            // Remove it, keeping the others in order.
            out.entries.copy_within(k + 1.., k);
            out.entries[DEPTH - 1] = None;
        }
        out
    }

    /// The stack of a ray that meets no surface any more: only the world's volume. An object's
    /// medium ends at its surface, so an object medium still held (its boundary passed
    /// unnoticed where it lies in the plane of another object's boundary the ray crossed) does
    /// not reach to infinity.
    pub fn escaping(&self) -> MediumStack {
        MediumStack::default()
    }

    /// The media of this stack in `ctx`'s scene, as `medium::fly` and
    /// `medium::transmittance` read them.
    pub fn media<'a>(&'a self, ctx: &'a Context) -> StackMedia<'a> {
        StackMedia {
            scene: ctx.scene,
            stack: self,
        }
    }

    /// The media of this stack: the world's, then each object's, with the object (mesh and
    /// instance) a heterogeneous medium reads its coordinates from.
    fn volumes<'a>(
        &'a self,
        scene: &'a Scene,
    ) -> impl Iterator<Item = (&'a Volume, Option<(u32, u32)>)> + 'a {
        let world = scene.world.volume.iter().map(|v| (v, None));
        world.chain(self.entries.iter().map_while(|e| *e).filter_map(|e| {
            let volume = scene.materials[e.material as usize].volume.as_ref()?;
            Some((volume, Some((e.mesh, e.instance))))
        }))
    }
}

/// A stack's media in a scene (`medium::Media`).
pub struct StackMedia<'a> {
    scene: &'a Scene,
    stack: &'a MediumStack,
}

impl Media for StackMedia<'_> {
    fn at(&self, p: Vec3, u: f32) -> Coefficients {
        let mut sum = Coefficients::VACUUM;
        let mut u = u;
        for (volume, object) in self.stack.volumes(self.scene) {
            let c = volume.at(self.scene, object, p, FRAME_TIME);
            // Each addition reuses what is left of `u` as a fresh uniform number.
            let mine = sum.scattering.element_sum();
            let theirs = c.scattering.element_sum();
            sum.add(&c, u);
            if theirs > 0.0 {
                let split = mine / (mine + theirs);
                u = if u < split {
                    u / split
                } else {
                    (u - split) / (1.0 - split)
                };
            }
        }
        sum
    }

    /// Homogeneous media of one phase function (scattering media of different phase
    /// functions are mixed point by point, as `at` does).
    fn homogeneous(&self) -> Option<Coefficients> {
        let mut sum = Coefficients::VACUUM;
        for (volume, _) in self.stack.volumes(self.scene) {
            let c = volume.constant?;
            let scatters = c.scattering != Vec3::ZERO;
            if scatters && sum.scattering != Vec3::ZERO && c.phase != sum.phase {
                return None;
            }
            sum.add(&c, 0.5);
        }
        Some(sum)
    }

    fn majorant(&self) -> f32 {
        self.stack
            .volumes(self.scene)
            .map(|(v, _)| v.majorant)
            .sum()
    }

    /// The media's majorants along the ray summed, holding until the first of them changes.
    fn majorant_along(&self, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
        let mut sum = 0.0;
        let mut end = f32::INFINITY;
        for (volume, object) in self.stack.volumes(self.scene) {
            let (majorant, until) = volume.majorant_along(self.scene, object, origin, dir, t);
            sum += majorant;
            end = end.min(until);
        }
        (sum, end)
    }
}
