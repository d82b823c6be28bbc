//! The scene's working colour space: the linear RGB space a Blender file's colours are in and
//! the render is computed and written in (Blender 5's per-file working space: Linear Rec.709,
//! Linear Rec.2020 or ACEScg; Blender 4 always Linear Rec.709). Colours the scene gives in the
//! working space (node trees, materials, lights) are used as they are; what is defined in
//! Rec.709 or by a spectrum (sRGB and linear Rec.709 images, Blender's sky, black bodies) is
//! taken into the working space by `from_rec709`, the matrix Blender's colour management uses
//! (primaries converted through CIE XYZ, D65 adapted to ACES' white by the Bradford transform
//! for ACEScg).

use crate::math::{Mat3, Vec3};

/// Blender's working colour spaces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WorkingSpace {
    #[default]
    Rec709,
    Rec2020,
    AcesCg,
}

impl WorkingSpace {
    /// The space of a Color Interop Forum identifier as Blender names them
    /// (`BlendFileColorspace.working_space_interop_id`).
    pub fn from_interop_id(id: &str) -> Option<WorkingSpace> {
        match id {
            "lin_rec709_scene" => Some(WorkingSpace::Rec709),
            "lin_rec2020_scene" => Some(WorkingSpace::Rec2020),
            "lin_ap1_scene" => Some(WorkingSpace::AcesCg),
            _ => None,
        }
    }

    /// Linear Rec.709 RGB to this space (columns: the images of Rec.709's red, green and blue).
    pub fn from_rec709(self) -> Mat3 {
        match self {
            WorkingSpace::Rec709 => Mat3::IDENTITY,
            WorkingSpace::Rec2020 => Mat3::from_cols(
                Vec3::new(0.627_403_9, 0.069_097_2, 0.016_391_5),
                Vec3::new(0.329_282_4, 0.919_54, 0.088_013_5),
                Vec3::new(0.043_312_5, 0.011_361_8, 0.895_594_9),
            ),
            WorkingSpace::AcesCg => Mat3::from_cols(
                Vec3::new(0.613_097_4, 0.070_193_6, 0.020_615_6),
                Vec3::new(0.339_522_6, 0.916_353_9, 0.109_57),
                Vec3::new(0.047_378_9, 0.013_451_9, 0.869_814_5),
            ),
        }
    }

    /// A linear Rec.709 colour in this space (unchanged in Rec.709).
    pub fn convert_rec709(self, c: Vec3) -> Vec3 {
        match self {
            WorkingSpace::Rec709 => c,
            space => space.from_rec709() * c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each matrix keeps white white (both spaces' whites are equal-energy RGB) and Rec.709's
    /// primaries fall inside the wider gamuts (no negative channel).
    #[test]
    fn white_stays_white_and_rec709_fits_inside() {
        for space in [
            WorkingSpace::Rec709,
            WorkingSpace::Rec2020,
            WorkingSpace::AcesCg,
        ] {
            let white = space.convert_rec709(Vec3::ONE);
            assert!(
                (white - Vec3::ONE).abs().max_element() < 1e-5,
                "{space:?} {white}"
            );
            for primary in [Vec3::X, Vec3::Y, Vec3::Z] {
                assert!(space.convert_rec709(primary).min_element() >= 0.0);
            }
        }
        assert_eq!(
            WorkingSpace::from_interop_id("lin_ap1_scene"),
            Some(WorkingSpace::AcesCg)
        );
        assert_eq!(WorkingSpace::from_interop_id("srgb_tx"), None);
    }
}
