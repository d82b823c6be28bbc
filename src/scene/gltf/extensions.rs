//! Photon's `PHOTON_*` glTF extensions (specified in `docs/gltf_extensions.md`) as typed
//! structures, each read once from its JSON object: every field is checked where it is read, and
//! a malformed value is refused with a message that names the field. The rest of the loader
//! uses these structures and never looks at the extensions' JSON.
//!
//! `PHOTON_material_nodes` is the exception: its tree is Blender's node graph, which
//! `crate::shader` compiles from the JSON itself.

use super::motion::Deformation;
use crate::color_space::WorkingSpace;
use crate::error::Error;
use crate::film::{FilterKind, FilterSettings};
use crate::math::{Affine3A, Mat3, Mat4, Vec2, Vec3};
use crate::scene::grids::ExtentRule;
use crate::scene::sky::NishitaSettings;
use crate::scene::{Lamp, LightLinks, Projection, Subsurface, SubsurfaceMethod, ThinLens};
use serde_json::Value;
use std::f32::consts::PI;

/// Why an extension was refused: `message`, about the field it names inside the object nested
/// at `at` (empty: the extension itself; "sky", "mix[1] sky", …).
#[derive(Debug)]
pub(super) struct Invalid {
    pub(super) at: String,
    pub(super) message: String,
}

impl Invalid {
    /// The glTF object to name in the error: the extension `object` and where inside it.
    pub(super) fn object(&self, object: &str) -> String {
        match self.at.as_str() {
            "" => object.to_string(),
            at => format!("{object} {at}"),
        }
    }
}

impl From<String> for Invalid {
    fn from(message: String) -> Self {
        Invalid {
            at: String::new(),
            message,
        }
    }
}

impl From<&str> for Invalid {
    fn from(message: &str) -> Self {
        Invalid::from(message.to_string())
    }
}

type Read<T> = std::result::Result<T, Invalid>;

/// The fields of one extension object, read one at a time; errors name the field and the
/// object it is nested in (`at`).
pub(super) struct Fields<'a> {
    object: &'a serde_json::Map<String, Value>,
    at: String,
}

impl<'a> Fields<'a> {
    /// The fields of `value`, which must be a JSON object.
    pub(super) fn of(value: &'a Value) -> Read<Fields<'a>> {
        Fields::nested_in(value, String::new())
    }

    fn nested_in(value: &'a Value, at: String) -> Read<Fields<'a>> {
        match value.as_object() {
            Some(object) => Ok(Fields { object, at }),
            None => Err(Invalid {
                at,
                message: format!("must be a JSON object, found {value}"),
            }),
        }
    }

    /// Where a field of this object is, for the object nested under `key`.
    fn inside(&self, key: &str) -> String {
        match self.at.as_str() {
            "" => key.to_string(),
            at => format!("{at} {key}"),
        }
    }

    fn get(&self, key: &str) -> Option<&'a Value> {
        self.object.get(key)
    }

    fn fail(&self, message: String) -> Invalid {
        Invalid {
            at: self.at.clone(),
            message,
        }
    }

    /// The object under `key`, if present.
    fn object(&self, key: &str) -> Read<Option<Fields<'a>>> {
        self.get(key)
            .map(|v| Fields::nested_in(v, self.inside(key)))
            .transpose()
    }

    /// A finite number for which `ok` holds, if present.
    fn optional_number(&self, key: &str, ok: fn(f32) -> bool) -> Read<Option<f32>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => match v.as_f64().map(|x| x as f32) {
                Some(x) if x.is_finite() && ok(x) => Ok(Some(x)),
                _ => Err(self.fail(format!("'{key}' is out of range: {v}"))),
            },
        }
    }

    /// A finite number for which `ok` holds; `default` when absent.
    fn number(&self, key: &str, default: f32, ok: fn(f32) -> bool) -> Read<f32> {
        Ok(self.optional_number(key, ok)?.unwrap_or(default))
    }

    fn flag(&self, key: &str, default: bool) -> Read<bool> {
        match self.get(key) {
            None => Ok(default),
            Some(v) => v
                .as_bool()
                .ok_or_else(|| self.fail(format!("'{key}' must be true or false, found {v}"))),
        }
    }

    fn string(&self, key: &str) -> Read<Option<&'a str>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_str()
                .map(Some)
                .ok_or_else(|| self.fail(format!("'{key}' must be a string, found {v}"))),
        }
    }

    /// The value of `choices` whose word `key` holds; the first's when absent.
    fn word<T: Copy>(&self, key: &str, choices: &[(&str, T)]) -> Read<T> {
        let Some(found) = self.string(key)? else {
            return Ok(choices[0].1);
        };
        match choices.iter().find(|(word, _)| *word == found) {
            Some(&(_, value)) => Ok(value),
            None => {
                let words: Vec<String> = choices.iter().map(|(w, _)| format!("\"{w}\"")).collect();
                Err(self.fail(format!(
                    "'{key}' must be {}, not \"{found}\"",
                    words.join(" or ")
                )))
            }
        }
    }

    /// Three finite numbers for which `ok` holds, if present; `what` says what they must be.
    fn vec3(&self, key: &str, what: &str, ok: fn(Vec3) -> bool) -> Read<Option<Vec3>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => numbers::<3>(v)
                .map(Vec3::from_array)
                .filter(|x| x.is_finite() && ok(*x))
                .map(Some)
                .ok_or_else(|| self.fail(format!("'{key}' must be {what}, found {v}"))),
        }
    }

    /// Two numbers for which `ok` holds; `default` when absent.
    fn pair(&self, key: &str, default: (f32, f32), ok: fn(f32) -> bool) -> Read<(f32, f32)> {
        match self.get(key) {
            None => Ok(default),
            Some(v) => match numbers::<2>(v) {
                Some([a, b]) if ok(a) && ok(b) => Ok((a, b)),
                Some(_) => Err(self.fail(format!("'{key}' is out of range: {v}"))),
                None => Err(self.fail(format!("'{key}' must be two numbers, found {v}"))),
            },
        }
    }
}

/// `N` numbers, when `value` is a list of exactly that many.
fn numbers<const N: usize>(value: &Value) -> Option<[f32; N]> {
    let list = value.as_array().filter(|a| a.len() == N)?;
    let mut out = [0.0; N];
    for (slot, x) in out.iter_mut().zip(list) {
        *slot = x.as_f64()? as f32;
    }
    Some(out)
}

fn any(_: f32) -> bool {
    true
}

fn non_negative(x: f32) -> bool {
    x >= 0.0
}

fn positive(x: f32) -> bool {
    x > 0.0
}

/// The `PHOTON_*` extensions of one node.
#[derive(Default)]
pub(super) struct NodeExtensions {
    pub(super) object: ObjectExtension,
    pub(super) light: Option<LightExtension>,
    pub(super) camera: Option<CameraExtension>,
}

impl NodeExtensions {
    /// `node`'s extensions; an error names the extension at fault.
    pub(super) fn read(node: &gltf::Node) -> std::result::Result<Self, (&'static str, Invalid)> {
        fn read<T>(
            node: &gltf::Node,
            name: &'static str,
            reader: fn(&Value) -> Read<T>,
        ) -> std::result::Result<Option<T>, (&'static str, Invalid)> {
            node.extension_value(name)
                .map(reader)
                .transpose()
                .map_err(|e| (name, e))
        }
        Ok(NodeExtensions {
            object: read(node, "PHOTON_object", ObjectExtension::read)?.unwrap_or_default(),
            light: read(node, "PHOTON_light", LightExtension::read)?,
            camera: read(node, "PHOTON_camera", CameraExtension::read)?,
        })
    }
}

/// `PHOTON_object` on a node.
pub(super) struct ObjectExtension {
    pub(super) camera_visible: bool,
    pub(super) casts_shadows: bool,
    pub(super) holdout: bool,
    /// Blender's texture space: location and size in object coordinates.
    pub(super) texture_space: Option<(Vec3, Vec3)>,
    /// World poses at evenly spaced moments of the shutter; empty: still.
    pub(super) motion: Vec<Affine3A>,
    pub(super) deform: Option<Deformation>,
    /// A Volume object's grids: the OpenVDB file and the names of its grids.
    pub(super) volume: Option<VolumeFile>,
    /// Blender's light and shadow linking ("light_linking").
    pub(super) links: LightLinks,
    pub(super) shadow_catcher: bool,
    /// What the Object Info node reads of the object (`object_info`).
    pub(super) info: crate::shader::ObjectInfo,
}

/// `PHOTON_object`'s "volume": the OpenVDB file that holds a Volume object's grids (a path,
/// absolute or relative to the glTF file), the names of the grids in it, and whether its
/// density is per unit of world length (Blender's volume space "World") rather than of the
/// object's own ("Object", the default).
pub(super) struct VolumeFile {
    pub(super) uri: String,
    pub(super) grids: Vec<String>,
    pub(super) world_space: bool,
    /// Voxels below this value hold no medium (Blender's `volume.render.clipping`; Cycles'
    /// default 0.001).
    pub(super) clipping: f32,
    /// A voxel's value sits at its index (Blender 5, OpenVDB's convention), else at index + ½
    /// (Blender 4).
    pub(super) values_at_index: bool,
    /// Which part of the box holds the medium ("extent": "leaves", the default, or
    /// "bounds").
    pub(super) extent: ExtentRule,
    /// Each lookup reads one voxel drawn by the trilinear weights ("interpolation":
    /// "stochastic", Blender 5) rather than their weighted sum ("linear", the default).
    pub(super) stochastic: bool,
    /// Index space (a voxel's value at its index) → object space, column-major, in place of
    /// the file's own transforms ("index_to_object": a fluid domain's grids fill its texture
    /// space).
    pub(super) index_to_object: Option<Mat4>,
    /// Attributes read from a grid of another name through a linear map ("attributes").
    pub(super) attributes: Vec<GridAttribute>,
}

/// An attribute the volume tree reads, made from grid `grid` of the file: each value `v`
/// becomes `offset + scale * v`, or 0 where `v` is not above `above` (when given).
pub(super) struct GridAttribute {
    pub(super) name: String,
    pub(super) grid: String,
    pub(super) scale: f32,
    pub(super) offset: f32,
    pub(super) above: Option<f32>,
}

impl VolumeFile {
    fn read(value: &Value) -> Read<VolumeFile> {
        let fields = Fields::of(value)?;
        let uri = fields
            .string("uri")?
            .ok_or_else(|| fields.fail("'uri' must be a string".into()))?;
        let grids = match fields.get("grids") {
            None => Vec::new(),
            Some(list) => list
                .as_array()
                .and_then(|a| a.iter().map(|g| g.as_str().map(str::to_string)).collect())
                .ok_or_else(|| fields.fail("'grids' must be a list of names".into()))?,
        };
        let world_space = fields.word("space", &[("object", false), ("world", true)])?;
        let extent = fields.word(
            "extent",
            &[
                ("leaves", ExtentRule::Leaves),
                ("bounds", ExtentRule::Bounds),
            ],
        )?;
        let stochastic =
            fields.word("interpolation", &[("linear", false), ("stochastic", true)])?;
        let clipping = match fields.get("clipping") {
            None => 0.001,
            Some(v) => match v.as_f64() {
                Some(c) if c.is_finite() && c >= 0.0 => c as f32,
                _ => return Err(fields.fail("'clipping' must be a number >= 0".into())),
            },
        };
        let index_to_object = match fields.get("index_to_object") {
            None => None,
            Some(v) => Some(
                numbers::<16>(v)
                    .map(|m| Mat4::from_cols_array(&m))
                    .filter(|m| m.is_finite() && m.determinant() != 0.0)
                    .ok_or_else(|| {
                        fields.fail(format!(
                            "'index_to_object' must be 16 numbers of an invertible matrix, found {v}"
                        ))
                    })?,
            ),
        };
        let mut attributes = Vec::new();
        if let Some(map) = fields.object("attributes")? {
            for (name, value) in map.object {
                let entry = Fields::nested_in(value, map.inside(name))?;
                let grid = entry
                    .string("grid")?
                    .ok_or_else(|| entry.fail("'grid' must be a string".into()))?;
                attributes.push(GridAttribute {
                    name: name.clone(),
                    grid: grid.to_string(),
                    scale: entry.number("scale", 1.0, any)?,
                    offset: entry.number("offset", 0.0, any)?,
                    above: entry.optional_number("above", any)?,
                });
            }
        }
        Ok(VolumeFile {
            uri: uri.to_string(),
            grids,
            world_space,
            clipping,
            values_at_index: fields.flag("values_at_index", false)?,
            extent,
            stochastic,
            index_to_object,
            attributes,
        })
    }
}

impl Default for ObjectExtension {
    fn default() -> Self {
        ObjectExtension {
            camera_visible: true,
            casts_shadows: true,
            holdout: false,
            texture_space: None,
            motion: Vec::new(),
            deform: None,
            volume: None,
            links: LightLinks::NONE,
            shadow_catcher: false,
            info: Default::default(),
        }
    }
}

impl ObjectExtension {
    pub(super) fn read(value: &Value) -> Read<ObjectExtension> {
        let fields = Fields::of(value)?;
        let texture_space = match fields.object("texture_space")? {
            None => None,
            Some(space) => {
                let three = |key: &str| {
                    space
                        .vec3(key, "three numbers", |_| true)?
                        .ok_or_else(|| space.fail(format!("'{key}' must be three numbers")))
                };
                Some((three("location")?, three("size")?))
            }
        };
        Ok(ObjectExtension {
            camera_visible: fields.flag("visible_camera", true)?,
            casts_shadows: fields.flag("visible_shadow", true)?,
            holdout: fields.flag("holdout", false)?,
            texture_space,
            motion: fields
                .get("motion")
                .map(read_poses)
                .transpose()?
                .unwrap_or_default(),
            deform: fields.get("deform").map(Deformation::read).transpose()?,
            volume: fields.get("volume").map(VolumeFile::read).transpose()?,
            links: match fields.object("light_linking")? {
                Some(linking) => read_light_links(linking)?,
                None => LightLinks::NONE,
            },
            shadow_catcher: fields.flag("shadow_catcher", false)?,
            info: fields
                .get("info")
                .map(super::object_info::read)
                .transpose()?
                .unwrap_or_default(),
        })
    }

    /// Whether the node moves or deforms while the shutter is open.
    pub(super) fn moves(&self) -> bool {
        !self.motion.is_empty() || self.deform.is_some()
    }
}

/// A "motion" of `PHOTON_camera` or `PHOTON_object`: two or more poses, each 16 numbers (a
/// column-major world matrix, glTF axes), finite and invertible.
fn read_poses(value: &Value) -> std::result::Result<Vec<Affine3A>, String> {
    let poses = value
        .as_array()
        .filter(|p| p.len() >= 2)
        .ok_or_else(|| format!("'motion' must be a list of two or more matrices, found {value}"))?;
    poses
        .iter()
        .map(|pose| {
            let bad = || format!("a 'motion' pose must be 16 finite numbers, found {pose}");
            let matrix = Mat4::from_cols_array(&numbers::<16>(pose).ok_or_else(bad)?);
            if !matrix.is_finite() || matrix.determinant().abs() < 1e-12 {
                return Err(bad());
            }
            Ok(Affine3A::from_mat4(matrix))
        })
        .collect()
}

/// `PHOTON_camera` on a camera node.
#[derive(Default)]
pub(super) struct CameraExtension {
    /// Lens shift in units of the image height.
    pub(super) shift: Vec2,
    pub(super) lens: Option<ThinLens>,
    /// A panoramic projection in place of the glTF camera's.
    pub(super) panorama: Option<Projection>,
    /// Rigid poses over the shutter; empty: still.
    pub(super) motion: Vec<Affine3A>,
}

impl CameraExtension {
    pub(super) fn read(value: &Value) -> Read<CameraExtension> {
        let fields = Fields::of(value)?;
        let shift = match fields.get("shift") {
            None => Vec2::ZERO,
            Some(v) => {
                let [x, y] = numbers::<2>(v)
                    .ok_or_else(|| format!("'shift' must be two numbers, found {v}"))?;
                let shift = Vec2::new(x, y);
                if !shift.is_finite() {
                    return Err(format!("'shift' must be finite, found {v}").into());
                }
                shift
            }
        };
        let lens = match fields.object("dof")? {
            None => None,
            Some(dof) => {
                let radius = dof.number("aperture_radius", 0.0, non_negative)?;
                let focus_distance = dof.number("focus_distance", 10.0, positive)?;
                let blades = dof.number("blades", 0.0, |x| (0.0..=1000.0).contains(&x))?;
                let rotation = dof.number("rotation", 0.0, any)?;
                let ratio = dof.number("ratio", 1.0, positive)?;
                (radius > 0.0).then_some(ThinLens {
                    radius,
                    focus_distance,
                    blades: blades as u32,
                    rotation,
                    ratio,
                })
            }
        };
        // Cameras are rigid: the scale goes.
        let motion = match fields.get("motion") {
            None => Vec::new(),
            Some(v) => read_poses(v)?
                .into_iter()
                .map(|m| {
                    let (_, rotation, translation) = m.to_scale_rotation_translation();
                    Affine3A::from_rotation_translation(rotation.normalize(), translation)
                })
                .collect(),
        };
        Ok(CameraExtension {
            shift,
            lens,
            panorama: fields.object("panorama")?.map(read_panorama).transpose()?,
            motion,
        })
    }
}

/// The `panorama` of `PHOTON_camera`: Cycles' equirectangular or fisheye projection.
fn read_panorama(fields: Fields) -> Read<Projection> {
    let finite = |x: f32| x.is_finite();
    let positive_number = |key: &str, default: f32| match fields.get(key) {
        None => Ok(default),
        Some(v) => match v.as_f64().map(|x| x as f32) {
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            _ => Err(fields.fail(format!("'{key}' must be a positive number, found {v}"))),
        },
    };
    match fields.string("type")? {
        Some("EQUIRECTANGULAR") => Ok(Projection::Equirectangular {
            longitude: fields.pair("longitude", (-PI, PI), finite)?,
            latitude: fields.pair("latitude", (-0.5 * PI, 0.5 * PI), finite)?,
        }),
        Some("FISHEYE_EQUIDISTANT") => Ok(Projection::FisheyeEquidistant {
            fov: positive_number("fov", PI)?,
        }),
        Some("FISHEYE_EQUISOLID") => Ok(Projection::FisheyeEquisolid {
            lens: positive_number("lens", 10.5)?,
            fov: positive_number("fov", PI)?,
            sensor: fields.pair("sensor", (36.0, 24.0), |x| x.is_finite() && x > 0.0)?,
        }),
        Some("FISHEYE_LENS_POLYNOMIAL") => {
            // Blender's defaults: the fit of a 50 mm lens on a 36 mm sensor.
            let k = match fields.get("k") {
                None => [
                    -1.1735144e-5,
                    -0.019988737,
                    -3.3525323e-6,
                    3.0992753e-6,
                    -2.6064646e-8,
                ],
                Some(v) => numbers::<5>(v)
                    .filter(|k| k.iter().all(|x| x.is_finite()))
                    .ok_or_else(|| fields.fail(format!("'k' must be five numbers, found {v}")))?,
            };
            Ok(Projection::FisheyePolynomial {
                k,
                fov: positive_number("fov", PI)?,
                sensor: fields.pair("sensor", (36.0, 24.0), |x| x.is_finite() && x > 0.0)?,
            })
        }
        Some("MIRRORBALL") => Ok(Projection::MirrorBall),
        Some("CENTRAL_CYLINDRICAL") => Ok(Projection::CentralCylindrical {
            longitude: fields.pair("longitude", (-PI, PI), finite)?,
            height: fields.pair("height", (-1.0, 1.0), finite)?,
        }),
        Some("EQUIANGULAR_CUBEMAP_FACE") => Ok(Projection::CubeMapFace),
        other => Err(fields.fail(format!(
            "unknown panorama type {other:?} (EQUIRECTANGULAR, FISHEYE_EQUIDISTANT, \
             FISHEYE_EQUISOLID, FISHEYE_LENS_POLYNOMIAL, MIRRORBALL, CENTRAL_CYLINDRICAL or \
             EQUIANGULAR_CUBEMAP_FACE)"
        ))),
    }
}

/// `PHOTON_light` on a node: an area light, or what it adds to the node's punctual light.
pub(super) enum LightExtension {
    Area(AreaLight),
    Punctual(PunctualExtension),
}

/// The outline of an area light.
#[derive(Clone, Copy, PartialEq, Debug)]
pub(super) enum AreaShape {
    Square,
    Rectangle,
    Disk,
    Ellipse,
}

/// A `PHOTON_light` area light.
pub(super) struct AreaLight {
    pub(super) shape: AreaShape,
    /// X extent (both extents for squares and disks).
    pub(super) size: f32,
    /// Y extent of rectangles and ellipses.
    pub(super) size_y: f32,
    /// Watts.
    pub(super) power: f32,
    pub(super) color: Vec3,
    pub(super) visible_camera: bool,
    /// Full spread angle in radians; π emits over the whole hemisphere.
    pub(super) spread: f32,
}

/// What `PHOTON_light` says of a point, spot or sun light.
pub(super) struct PunctualExtension {
    /// Cycles' colour; with it, `power` (point, spot) or `strength` (sun) replace the glTF
    /// light's photometric intensity.
    pub(super) color: Option<Vec3>,
    /// Watts.
    pub(super) power: Option<f32>,
    /// Sun irradiance, W/m².
    pub(super) strength: Option<f32>,
    /// Lamp radius in metres.
    pub(super) radius: f32,
    pub(super) lamp: Lamp,
    /// Sun angular diameter in radians.
    pub(super) angle: f32,
    /// Cycles' spot cone: full angle in radians, and blend in [0, 1].
    pub(super) spot_size: Option<f32>,
    pub(super) spot_blend: Option<f32>,
}

impl Default for PunctualExtension {
    fn default() -> Self {
        PunctualExtension {
            color: None,
            power: None,
            strength: None,
            radius: 0.0,
            lamp: Lamp::default(),
            angle: 0.0,
            spot_size: None,
            spot_blend: None,
        }
    }
}

impl LightExtension {
    pub(super) fn read(value: &Value) -> Read<LightExtension> {
        let fields = Fields::of(value)?;
        if fields.string("type")? == Some("area") {
            let shape = match fields.string("shape")?.unwrap_or("SQUARE") {
                "SQUARE" => AreaShape::Square,
                "RECTANGLE" => AreaShape::Rectangle,
                "DISK" => AreaShape::Disk,
                "ELLIPSE" => AreaShape::Ellipse,
                other => return Err(format!("unknown area light shape '{other}'").into()),
            };
            let size = fields.number("size", 1.0, any)?;
            let spread = fields.number("spread", PI, any)?;
            if !(0.0..=PI).contains(&spread) {
                return Err(format!(
                    "area light spread {spread} is not an angle in [0, π] radians"
                )
                .into());
            }
            return Ok(LightExtension::Area(AreaLight {
                shape,
                size,
                size_y: fields.number("size_y", size, any)?,
                power: fields.number("power", 10.0, any)?,
                color: fields
                    .vec3("color", "three numbers", |_| true)?
                    .unwrap_or(Vec3::ONE),
                visible_camera: fields.flag("visible_camera", false)?,
                spread,
            }));
        }
        let defaults = Lamp::default();
        Ok(LightExtension::Punctual(PunctualExtension {
            color: fields.vec3("color", "three numbers ≥ 0", |c| c.min_element() >= 0.0)?,
            power: fields.optional_number("power", non_negative)?,
            strength: fields.optional_number("strength", non_negative)?,
            radius: fields.number("radius", 0.0, any)?,
            lamp: Lamp {
                soft_falloff: fields.flag("soft_falloff", defaults.soft_falloff)?,
                camera: fields.flag("visible_camera", defaults.camera)?,
                bounces: fields.flag("visible_bounces", defaults.bounces)?,
            },
            angle: fields.number("angle", 0.0, any)?,
            spot_size: fields.optional_number("spot_size", |x| x > 0.0 && x <= PI)?,
            spot_blend: fields.optional_number("spot_blend", |x| (0.0..=1.0).contains(&x))?,
        }))
    }
}

/// `PHOTON_world` on a scene: the background, and what camera rays see in its place.
pub(super) struct WorldExtension {
    pub(super) background: Vec<BackgroundLayer>,
    pub(super) camera: Option<Vec<BackgroundLayer>>,
    /// What feeds the World Output's Volume: a node tree as `PHOTON_material_nodes` has them.
    pub(super) volume: Option<Value>,
}

/// One background of a world (the world's own, or an entry of its `mix`), summed with the
/// others.
pub(super) struct BackgroundLayer {
    /// `strength` × `weight`.
    pub(super) strength: f32,
    pub(super) source: BackgroundSource,
}

pub(super) enum BackgroundSource {
    Color(Vec3),
    Environment(EnvironmentTexture),
    Sky(SkyTexture),
}

/// Blender's Environment Texture: an equirectangular OpenEXR beside the glTF file.
pub(super) struct EnvironmentTexture {
    pub(super) uri: String,
    /// The Mapping node's rotation, applied to directions before the lookup.
    pub(super) rotation: Mat3,
    pub(super) closest: bool,
}

/// Blender's Sky Texture: its model and that model's settings.
pub(super) struct SkyTexture {
    pub(super) model: SkyModel,
    pub(super) rotation: Mat3,
}

/// The sky models of Blender's Sky Texture that Photon evaluates.
pub(super) enum SkyModel {
    Nishita(NishitaSettings),
    /// Blender 5's Multiple Scattering sky: the Nishita sky's settings, `dust` its aerosols.
    MultipleScattering(NishitaSettings),
    /// The sun towards `sun_direction` (Blender's Sun Direction, any length but zero).
    Preetham {
        sun_direction: Vec3,
        turbidity: f32,
    },
    HosekWilkie {
        sun_direction: Vec3,
        turbidity: f32,
        ground_albedo: f32,
    },
}

impl WorldExtension {
    pub(super) fn read(value: &Value) -> Read<WorldExtension> {
        let fields = Fields::of(value)?;
        Ok(WorldExtension {
            background: read_layers(&fields)?,
            camera: fields
                .object("camera")?
                .map(|camera| read_layers(&camera))
                .transpose()?,
            volume: fields.get("volume").cloned(),
        })
    }
}

/// A background: its `mix` entries, or the object itself as the one layer.
fn read_layers(fields: &Fields) -> Read<Vec<BackgroundLayer>> {
    let Some(mix) = fields.get("mix") else {
        return Ok(vec![read_layer(fields)?]);
    };
    let entries = mix
        .as_array()
        .ok_or_else(|| fields.fail(format!("'mix' must be a list, found {mix}")))?;
    entries
        .iter()
        .enumerate()
        .map(|(i, entry)| {
            read_layer(&Fields::nested_in(
                entry,
                fields.inside(&format!("mix[{i}]")),
            )?)
        })
        .collect()
}

fn read_layer(fields: &Fields) -> Read<BackgroundLayer> {
    let factor = |key: &str| match fields.get(key) {
        None => Ok(1.0),
        Some(v) => v
            .as_f64()
            .map(|x| x as f32)
            .filter(|x| x.is_finite())
            .ok_or_else(|| fields.fail(format!("'{key}' must be a number: {v}"))),
    };
    let strength = factor("strength")? * factor("weight")?;
    let source = if let Some(env) = fields.object("environment")? {
        let uri = env
            .string("uri")?
            .ok_or_else(|| env.fail("'uri' (the environment image) is missing".into()))?;
        let closest = match env.string("interpolation")? {
            None | Some("linear") => false,
            Some("closest") => true,
            Some(other) => {
                return Err(env.fail(format!(
                    "unknown interpolation '{other}' (linear or closest)"
                )))
            }
        };
        BackgroundSource::Environment(EnvironmentTexture {
            uri: uri.to_string(),
            rotation: mapping_rotation(&env)?,
            closest,
        })
    } else if let Some(sky) = fields.object("sky")? {
        BackgroundSource::Sky(read_sky(&sky)?)
    } else {
        let color = fields.vec3("color", "[r, g, b]", |_| true)?;
        BackgroundSource::Color(color.unwrap_or(Vec3::ZERO))
    };
    Ok(BackgroundLayer { strength, source })
}

fn read_sky(sky: &Fields) -> Read<SkyTexture> {
    let analytic = |hosek: bool| -> Read<SkyModel> {
        let sun_direction = sky
            .vec3("sun_direction", "a non-zero [x, y, z]", |v| v != Vec3::ZERO)?
            .unwrap_or(Vec3::Z);
        let turbidity = sky.number("turbidity", 2.2, |t| (1.0..=10.0).contains(&t))?;
        Ok(if hosek {
            SkyModel::HosekWilkie {
                sun_direction,
                turbidity,
                ground_albedo: sky.number("ground_albedo", 0.3, |a| (0.0..=1.0).contains(&a))?,
            }
        } else {
            SkyModel::Preetham {
                sun_direction,
                turbidity,
            }
        })
    };
    let model = match sky.string("type")? {
        None | Some("NISHITA") => SkyModel::Nishita(read_nishita(sky)?),
        Some("MULTIPLE_SCATTERING") => SkyModel::MultipleScattering(read_nishita(sky)?),
        Some("PREETHAM") => analytic(false)?,
        Some("HOSEK_WILKIE") => analytic(true)?,
        Some(other) => {
            return Err(sky.fail(format!(
                "unknown sky type '{other}' (NISHITA, MULTIPLE_SCATTERING, PREETHAM or \
                 HOSEK_WILKIE)"
            )))
        }
    };
    Ok(SkyTexture {
        model,
        rotation: mapping_rotation(sky)?,
    })
}

/// The settings of a Nishita or Multiple Scattering sky.
fn read_nishita(sky: &Fields) -> Read<NishitaSettings> {
    let defaults = NishitaSettings::default();
    let settings = NishitaSettings {
        sun_elevation: sky.number("sun_elevation", defaults.sun_elevation, any)?,
        sun_rotation: sky.number("sun_rotation", defaults.sun_rotation, any)?,
        sun_size: sky.number("sun_size", defaults.sun_size, |x| (0.0..=PI).contains(&x))?,
        sun_intensity: sky.number("sun_intensity", defaults.sun_intensity, non_negative)?,
        sun_disc: sky.flag("sun_disc", defaults.sun_disc)?,
        altitude: sky.number("altitude", defaults.altitude, any)?,
        air: sky.number("air", defaults.air, non_negative)?,
        dust: sky.number("dust", defaults.dust, non_negative)?,
        ozone: sky.number("ozone", defaults.ozone, non_negative)?,
    };
    Ok(settings)
}

/// The rotation of a Mapping node (`"rotation": [x, y, z]`, Blender's Euler XYZ, radians)
/// applied to directions in Blender's frame before a world texture's lookup.
fn mapping_rotation(texture: &Fields) -> Read<Mat3> {
    let rotation = texture
        .vec3("rotation", "[x, y, z]", |_| true)?
        .unwrap_or(Vec3::ZERO);
    // X first, then Y, then Z.
    Ok(Mat3::from_rotation_z(rotation.z)
        * Mat3::from_rotation_y(rotation.y)
        * Mat3::from_rotation_x(rotation.x))
}

/// `PHOTON_object`'s "light_linking": as an emitter its `receiver_set` and `blocker_set`
/// (1–63), as an object the sets it is left out of, `not_lit_by` and `not_blocking`.
fn read_light_links(linking: Fields) -> Read<LightLinks> {
    let set = |key: &str| match linking.get(key) {
        None => Ok(0),
        Some(v) => match v.as_u64().filter(|k| (1..64).contains(k)) {
            Some(k) => Ok(k as u8),
            None => Err(linking.fail(format!("'{key}' must be an integer in 1..=63, found {v}"))),
        },
    };
    let mask = |key: &str| match linking.get(key) {
        None => Ok(u64::MAX),
        Some(v) => {
            let sets: Option<Vec<u64>> = v.as_array().and_then(|a| {
                a.iter()
                    .map(|k| k.as_u64().filter(|k| (1..64).contains(k)))
                    .collect()
            });
            match sets {
                Some(sets) => Ok(sets.iter().fold(u64::MAX, |m, &k| m & !(1u64 << k))),
                None => Err(linking.fail(format!(
                    "'{key}' must be a list of integers in 1..=63, found {v}"
                ))),
            }
        }
    };
    Ok(LightLinks {
        lit_by: mask("not_lit_by")?,
        blocks: mask("not_blocking")?,
        receiver_set: set("receiver_set")?,
        blocker_set: set("blocker_set")?,
    })
}

/// `PHOTON_render` on a scene.
pub(super) struct RenderExtension {
    pub(super) width: Option<u32>,
    pub(super) height: Option<u32>,
    pub(super) film_transparent: bool,
    pub(super) filter: Option<FilterSettings>,
    /// Blender's Volume bounces (0 when absent, as Blender's default).
    pub(super) volume_bounces: u32,
    /// Blender's Clamp Direct and Clamp Indirect (0, no limit, when absent).
    pub(super) clamp_direct: f32,
    pub(super) clamp_indirect: f32,
    /// Blender's Reflective and Refractive Caustics (on when absent) and Filter Glossy (0, off,
    /// when absent).
    pub(super) caustics_reflective: bool,
    pub(super) caustics_refractive: bool,
    pub(super) filter_glossy: f32,
    /// Blender's working colour space (Rec.709 when absent).
    pub(super) working_space: WorkingSpace,
}

impl RenderExtension {
    pub(super) fn read(value: &Value) -> Read<RenderExtension> {
        let fields = Fields::of(value)?;
        let dimension = |key: &str| match fields.get(key) {
            None => Ok(None),
            Some(v) => match v.as_u64().and_then(|v| u32::try_from(v).ok()) {
                Some(d) if d > 0 => Ok(Some(d)),
                _ => Err(format!("'{key}' must be a positive integer, found {v}")),
            },
        };
        Ok(RenderExtension {
            width: dimension("width")?,
            height: dimension("height")?,
            film_transparent: fields.flag("film_transparent", false)?,
            filter: fields.object("filter")?.map(read_filter).transpose()?,
            volume_bounces: match fields.get("volume_bounces") {
                None => 0,
                Some(v) => match v.as_u64().filter(|&n| n <= 1024) {
                    Some(n) => n as u32,
                    None => {
                        return Err(fields.fail(format!(
                            "'volume_bounces' must be an integer in 0..=1024, found {v}"
                        )))
                    }
                },
            },
            clamp_direct: fields.number("clamp_direct", 0.0, non_negative)?,
            clamp_indirect: fields.number("clamp_indirect", 0.0, non_negative)?,
            caustics_reflective: fields.flag("caustics_reflective", true)?,
            caustics_refractive: fields.flag("caustics_refractive", true)?,
            filter_glossy: fields.number("filter_glossy", 0.0, non_negative)?,
            working_space: match fields.string("working_space")? {
                None => WorkingSpace::Rec709,
                Some(id) => WorkingSpace::from_interop_id(id).ok_or_else(|| {
                    fields.fail(format!(
                        "unknown working space '{id}' (lin_rec709_scene, lin_rec2020_scene or \
                         lin_ap1_scene)"
                    ))
                })?,
            },
        })
    }
}

/// `PHOTON_render`'s `filter`: Cycles' pixel filter type and Blender's width.
fn read_filter(filter: Fields) -> Read<FilterSettings> {
    let name = filter.string("type")?.unwrap_or("");
    let kind = FilterKind::from_name(name).ok_or_else(|| {
        filter.fail(format!(
            "'type' must be BLACKMAN_HARRIS, GAUSSIAN or BOX, found {name:?}"
        ))
    })?;
    let width = match filter.get("width") {
        None => kind.default_width(),
        Some(w) => w
            .as_f64()
            .ok_or_else(|| filter.fail(format!("'width' must be a number, found {w}")))?
            as f32,
    };
    FilterSettings::new(kind, width).map_err(|e| match e {
        Error::Settings(message) => filter.fail(message),
        e => filter.fail(e.to_string()),
    })
}

/// `PHOTON_material_subsurface` on a material: Blender's Principled subsurface inputs, every
/// field optional (Blender's defaults), every value finite; weight in [0, 1], radius and scale
/// ≥ 0, IOR > 0, anisotropy in (−1, 1).
pub(super) fn read_subsurface(value: &Value) -> Read<Subsurface> {
    let fields = Fields::of(value)?;
    let defaults = Subsurface::default();
    let method = match fields.get("method") {
        None => defaults.method,
        Some(v) => v
            .as_str()
            .and_then(SubsurfaceMethod::from_blender)
            .ok_or_else(|| {
                format!(
                    "'method' must be \"BURLEY\", \"RANDOM_WALK\" or \"RANDOM_WALK_SKIN\", \
                     found {v}"
                )
            })?,
    };
    Ok(Subsurface {
        method,
        weight: fields.number("weight", defaults.weight, |x| (0.0..=1.0).contains(&x))?,
        radius: fields
            .vec3("radius", "three numbers ≥ 0", |r| r.min_element() >= 0.0)?
            .unwrap_or(defaults.radius),
        scale: fields.number("scale", defaults.scale, non_negative)?,
        ior: fields.number("ior", defaults.ior, positive)?,
        anisotropy: fields.number("anisotropy", defaults.anisotropy, |x| x.abs() < 1.0)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn messages_name_the_field_and_where_it_is() {
        let sky = WorldExtension::read(&json!({"mix": [{}, {"sky": {"dust": -1}}]}));
        let invalid = sky.err().unwrap();
        assert_eq!(invalid.object("PHOTON_world"), "PHOTON_world mix[1] sky");
        assert_eq!(invalid.message, "'dust' is out of range: -1");
        let object = ObjectExtension::read(&json!({"visible_shadow": 0}));
        assert!(object.err().unwrap().message.contains("'visible_shadow'"));
    }

    /// A fluid domain's volume: its own index-to-object transform and attributes made from
    /// grids of other names; a singular transform or an attribute without a grid is refused.
    #[test]
    fn fluid_volume_fields_are_read() {
        let volume = |extra: Value| {
            let mut value = json!({"uri": "fluid_data_0008.vdb"});
            value
                .as_object_mut()
                .unwrap()
                .extend(extra.as_object().unwrap().clone());
            VolumeFile::read(&value)
        };
        let plain = volume(json!({})).unwrap();
        assert!(plain.index_to_object.is_none() && plain.attributes.is_empty());
        let matrix = [
            0.125, 0., 0., 0., 0., 0.125, 0., 0., 0., 0., 0.25, 0., -0.9, -0.9, 0.1, 1.,
        ];
        let fluid = volume(json!({
            "index_to_object": matrix,
            "attributes": {"temperature": {"grid": "flame", "above": 0.01, "offset": 1.5,
                                           "scale": 1.5},
                           "heat": {"grid": "temperature", "scale": 0.5}}
        }))
        .unwrap();
        assert_eq!(fluid.index_to_object, Some(Mat4::from_cols_array(&matrix)));
        let heat = fluid.attributes.iter().find(|a| a.name == "heat").unwrap();
        assert_eq!(
            (heat.grid.as_str(), heat.scale, heat.offset, heat.above),
            ("temperature", 0.5, 0.0, None)
        );
        let hot = fluid
            .attributes
            .iter()
            .find(|a| a.name == "temperature")
            .unwrap();
        assert_eq!((hot.grid.as_str(), hot.above), ("flame", Some(0.01)));
        let zeros = vec![0.0f32; 16];
        let singular = volume(json!({ "index_to_object": zeros }));
        assert!(singular
            .err()
            .unwrap()
            .message
            .contains("'index_to_object'"));
        let gridless = volume(json!({"attributes": {"heat": {"scale": 0.5}}}));
        let invalid = gridless.err().unwrap();
        assert_eq!(
            (invalid.at.as_str(), invalid.message.as_str()),
            ("attributes heat", "'grid' must be a string")
        );
    }

    #[test]
    fn absent_fields_take_their_defaults() {
        let object = ObjectExtension::read(&json!({})).unwrap();
        assert!(object.camera_visible && object.casts_shadows && !object.holdout);
        assert!(!object.moves());
        let Ok(LightExtension::Area(area)) = LightExtension::read(&json!({"type": "area"})) else {
            panic!("an area light");
        };
        assert_eq!(
            (area.shape, area.size, area.size_y),
            (AreaShape::Square, 1.0, 1.0)
        );
        assert_eq!((area.power, area.spread), (10.0, PI));
    }

    /// The analytic skies and the panoramas added to Cycles' set are read with their fields
    /// and defaults; a zero sun direction or an unknown type is refused.
    #[test]
    fn analytic_skies_and_more_panoramas_are_read() {
        let layer = |value| {
            WorldExtension::read(&json!({ "sky": value }))
                .map(|mut w| w.background.remove(0).source)
        };
        let Ok(BackgroundSource::Sky(sky)) =
            layer(json!({"type": "HOSEK_WILKIE", "sun_direction": [0, 1, 1]}))
        else {
            panic!("a sky");
        };
        let SkyModel::HosekWilkie {
            sun_direction,
            turbidity,
            ground_albedo,
        } = sky.model
        else {
            panic!("Hosek-Wilkie");
        };
        assert_eq!(
            (sun_direction, turbidity, ground_albedo),
            (Vec3::new(0.0, 1.0, 1.0), 2.2, 0.3)
        );
        let Ok(BackgroundSource::Sky(sky)) = layer(json!({"type": "PREETHAM", "turbidity": 4}))
        else {
            panic!("a sky");
        };
        assert!(matches!(sky.model, SkyModel::Preetham { turbidity, .. } if turbidity == 4.0));
        assert!(layer(json!({"type": "PREETHAM", "sun_direction": [0, 0, 0]})).is_err());
        let Ok(BackgroundSource::Sky(sky)) =
            layer(json!({"type": "MULTIPLE_SCATTERING", "altitude": 250, "dust": 2}))
        else {
            panic!("a sky");
        };
        assert!(matches!(sky.model, SkyModel::MultipleScattering(s)
            if s.altitude == 250.0 && s.dust == 2.0 && s.air == 1.0));
        assert!(layer(json!({"type": "MULTIPLE"})).is_err());
        let panorama =
            |value| CameraExtension::read(&json!({ "panorama": value })).map(|c| c.panorama);
        assert_eq!(
            panorama(json!({"type": "MIRRORBALL"})).ok(),
            Some(Some(Projection::MirrorBall))
        );
        assert_eq!(
            panorama(
                json!({"type": "FISHEYE_LENS_POLYNOMIAL", "k": [0, -0.03, 0, 0, 0], "fov": 2})
            )
            .ok(),
            Some(Some(Projection::FisheyePolynomial {
                k: [0.0, -0.03, 0.0, 0.0, 0.0],
                fov: 2.0,
                sensor: (36.0, 24.0)
            }))
        );
        assert!(panorama(json!({"type": "FISHEYE_LENS_POLYNOMIAL", "k": [1, 2]})).is_err());
    }
}
