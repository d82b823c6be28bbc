//! Tests of the Principled BSDF: chi-square of `ViewedBsdf::sample` against `ViewedBsdf::pdf` for every lobe
//! family (the harness also checks that the pdf integrates to at most 1 and that the samples it
//! does not produce are the missing mass), coat, sheen and anisotropic lobes included,
//! agreement of sample weights with eval/pdf, hemisphere rules, reciprocity, white furnace,
//! layering, smooth-glass Fresnel split and robustness at extreme inputs.

use crate::support::chi2::chi2_sphere;
use photon::bsdf::fresnel::fresnel_dielectric;
use photon::bsdf::Bsdf;
use photon::material::SurfaceMaterial;
use photon::math::Vec3;
use photon::rng::Rng;

fn material(base: Vec3, metallic: f32, roughness: f32, transmission: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        base_color: base,
        metallic,
        roughness,
        transmission,
        ..SurfaceMaterial::default()
    }
}

struct Case {
    name: String,
    bsdf: Bsdf,
    /// Test from inside (wo.z < 0) too.
    inside: bool,
}

fn case(name: &str, m: SurfaceMaterial, inside: bool) -> Case {
    Case {
        name: name.to_string(),
        bsdf: Bsdf::new(&m),
        inside,
    }
}

/// Every rough lobe family the chi-square test covers.
fn rough_cases() -> Vec<Case> {
    let grey = Vec3::splat(0.8);
    let gold = Vec3::new(0.9, 0.6, 0.3);
    let tinted_glass = Vec3::new(0.95, 0.85, 0.7);
    let mut cases = vec![case(
        "diffuse layer",
        SurfaceMaterial {
            specular: 0.0,
            ..material(grey, 0.0, 0.5, 0.0)
        },
        false,
    )];
    for r in [0.1, 0.5, 1.0] {
        // A black base leaves only the specular layer.
        cases.push(case(
            &format!("dielectric specular r={r}"),
            material(Vec3::ZERO, 0.0, r, 0.0),
            false,
        ));
    }
    for r in [0.1, 0.5] {
        cases.push(case(
            &format!("metal r={r}"),
            material(gold, 1.0, r, 0.0),
            false,
        ));
    }
    for r in [0.2, 0.6] {
        cases.push(case(
            &format!("rough glass r={r}"),
            material(tinted_glass, 0.0, r, 1.0),
            true,
        ));
    }
    cases.push(case(
        "mixture metallic 0.5",
        material(grey, 0.5, 0.4, 0.0),
        false,
    ));
    cases.push(case(
        "mixture transmission 0.5",
        material(grey, 0.0, 0.4, 0.5),
        false,
    ));
    let red = Vec3::new(0.8, 0.1, 0.05);
    for r in [0.1, 0.4] {
        cases.push(case(
            &format!("coat r={r} over red"),
            coated(material(red, 0.0, 0.5, 0.0), r),
            false,
        ));
    }
    let tilted = Vec3::new(0.3, -0.2, 0.93).normalize();
    cases.push(Case {
        name: "coat tilted over metal".into(),
        bsdf: Bsdf::new(&coated(material(gold, 1.0, 0.3, 0.0), 0.2)).with_coat_normal(tilted),
        inside: false,
    });
    cases.push(case(
        "coat over rough glass",
        coated(material(tinted_glass, 0.0, 0.4, 1.0), 0.3),
        true,
    ));
    for r in [0.2, 0.7] {
        cases.push(case(
            &format!("sheen r={r} alone"),
            SurfaceMaterial {
                specular: 0.0,
                ..sheened(material(Vec3::ZERO, 0.0, 0.5, 0.0), r)
            },
            false,
        ));
    }
    cases.push(case(
        "sheen over grey",
        sheened(material(grey, 0.0, 0.5, 0.0), 0.5),
        false,
    ));
    for aspect in [0.3, 0.6] {
        cases.push(case(
            &format!("anisotropic metal aspect={aspect}"),
            SurfaceMaterial {
                aspect,
                ..material(gold, 1.0, 0.4, 0.0)
            },
            false,
        ));
    }
    cases.push(case(
        "anisotropic specular",
        SurfaceMaterial {
            aspect: 0.4,
            ..material(Vec3::ZERO, 0.0, 0.3, 0.0)
        },
        false,
    ));
    // Oren–Nayar diffuse (Blender's Diffuse Roughness), alone and under the specular layer.
    for (sigma, specular) in [(1.0, 0.0), (0.5, 1.0)] {
        cases.push(case(
            &format!("rough diffuse σ={sigma} specular={specular}"),
            SurfaceMaterial {
                specular,
                diffuse_roughness: sigma,
                ..material(Vec3::new(0.9, 0.5, 0.2), 0.0, 0.4, 0.0)
            },
            false,
        ));
    }
    // Blender's Translucent BSDF: Lambertian transmission, seen from either side.
    cases.push(case(
        "translucent",
        translucent(Vec3::new(0.9, 0.6, 0.3)),
        true,
    ));
    // KHR_materials_diffuse_transmission: the base's diffuse lobe split into reflection and
    // Lambertian transmission, without the specular layer and under it.
    for specular in [0.0, 1.0] {
        cases.push(case(
            &format!("translucent base specular={specular}"),
            transmitting_base(Vec3::new(0.3, 0.75, 0.4), 0.7, specular),
            true,
        ));
    }
    for r in [0.3, 0.8] {
        cases.push(case(
            &format!("refraction r={r}"),
            refraction(tinted_glass, r),
            true,
        ));
    }
    for r in [0.2, 0.6] {
        cases.push(case(
            &format!("thin film specular r={r}"),
            film(material(Vec3::new(0.2, 0.3, 0.5), 0.0, r, 0.0), 500.0),
            false,
        ));
        cases.push(case(
            &format!("thin film glass r={r}"),
            film(material(tinted_glass, 0.0, r, 1.0), 350.0),
            true,
        ));
    }
    cases.push(Case {
        name: "layered sheen, tinted coat, anisotropic mixture".into(),
        bsdf: Bsdf::new(&SurfaceMaterial {
            aspect: 0.5,
            coat_tint: Vec3::new(0.9, 0.6, 0.3),
            ..sheened(coated(material(grey, 0.5, 0.3, 0.0), 0.25), 0.4)
        })
        .with_coat_normal(tilted),
        inside: false,
    });
    cases
}

/// `m` under a thin film `thickness` nm thick, of IOR 1.33 (Blender's default).
fn film(m: SurfaceMaterial, thickness: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        thin_film_thickness: thickness,
        thin_film_ior: 1.33,
        ..m
    }
}

/// A dielectric base of colour `base` whose diffuse lobe transmits the share `share` in orange
/// (KHR_materials_diffuse_transmission), roughness 0.5, with the specular layer's level
/// `specular`.
fn transmitting_base(base: Vec3, share: f32, specular: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        specular,
        diffuse_transmission: share,
        diffuse_transmission_color: Vec3::new(1.0, 0.55, 0.25),
        ..material(base, 0.0, 0.5, 0.0)
    }
}

#[test]
fn diffuse_transmission_splits_the_diffuse_base() {
    // Without a specular layer: f = (1 − t)·base / π on the viewer's side and t·colour / π on
    // the other, seen from either side, and the density is the lobes' cosine densities.
    let base = Vec3::new(0.3, 0.75, 0.4);
    let b = Bsdf::new(&transmitting_base(base, 0.7, 0.0));
    assert!(b.is_transmissive());
    let reflect = base * 0.3 / std::f32::consts::PI;
    let transmit = Vec3::new(1.0, 0.55, 0.25) * 0.7 / std::f32::consts::PI;
    let mut rng = Rng::new(11);
    for _ in 0..2000 {
        let a = photon::sampling::square_to_uniform_sphere(rng.uniform2());
        let c = photon::sampling::square_to_uniform_sphere(rng.uniform2());
        if a.z.abs() < 1e-3 || c.z.abs() < 1e-3 {
            continue;
        }
        let f = b.viewed_from(a).eval(c) / c.z.abs();
        let expected = if a.z * c.z < 0.0 { transmit } else { reflect };
        assert!((f - expected).length() < 1e-5, "{f:?} vs {expected:?}");
    }
    // White furnace: a white base transmitting half its diffuse light in white, under the
    // energy-compensated specular layer, scatters all the light from either side.
    let white = Bsdf::new(&SurfaceMaterial {
        diffuse_transmission: 0.5,
        ..material(Vec3::ONE, 0.0, 0.5, 0.0)
    });
    for &mu in &[1.0, 0.5, 0.1, -0.5] {
        let (albedo, err) = measured_albedo(&white, view(mu), 200_000, 12);
        println!("white transmitting base μ={mu}: {albedo:?} ± {err}");
        assert!(
            (albedo - Vec3::ONE).abs().max_element() < 0.025,
            "μ={mu}: {albedo:?}"
        );
    }
}

/// A Translucent BSDF node's material (`Closure::translucent`).
fn translucent(color: Vec3) -> SurfaceMaterial {
    SurfaceMaterial {
        translucent: true,
        ..material(color, 0.0, 1.0, 1.0)
    }
}

/// A Refraction BSDF node's material (`Closure::refraction`): the glass's transmission alone.
fn refraction(color: Vec3, roughness: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        refraction: true,
        ..material(color, 0.0, roughness, 1.0)
    }
}

fn coated(m: SurfaceMaterial, roughness: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        coat_weight: 1.0,
        coat_roughness: roughness,
        ..m
    }
}

fn sheened(m: SurfaceMaterial, roughness: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        sheen_weight: 1.0,
        sheen_roughness: roughness,
        sheen_tint: Vec3::new(1.0, 0.9, 0.8),
        ..m
    }
}

/// Viewing directions: several elevations, off-axis azimuths; mirrored below for inside cases.
fn view_directions(inside: bool) -> Vec<Vec3> {
    let mut dirs = Vec::new();
    for (k, &mu) in [0.9f32, 0.5, 0.15].iter().enumerate() {
        let phi = 0.7 + 1.9 * k as f32;
        let s = (1.0 - mu * mu).sqrt();
        dirs.push(Vec3::new(s * phi.cos(), s * phi.sin(), mu));
        if inside {
            dirs.push(Vec3::new(s * phi.cos(), s * phi.sin(), -mu));
        }
    }
    dirs
}

/// 1 + 9 + 6 + 12 + 6 + 15 + 9 + 9 + 3 + 6 + 6 + 12 chi-square tests below.
const NUM_CHI2_TESTS: usize = 96;

/// Chi-square tests of the rough cases whose name starts with `family`.
fn chi2_family(family: &str) {
    let mut failures = Vec::new();
    for (index, c) in rough_cases().into_iter().enumerate() {
        if !c.name.starts_with(family) {
            continue;
        }
        for (k, wo) in view_directions(c.inside).into_iter().enumerate() {
            let mut rng = Rng::for_item(99, index as u64, k as u64);
            // The view's lobes once per direction, not once per sample or pdf evaluation (the
            // pdf's integration over the bins calls it millions of times).
            let viewed = c.bsdf.viewed_from(wo);
            let result = chi2_sphere(
                &format!("{} wo={wo:?}", c.name),
                300_000,
                |_| {
                    let u_lobe = rng.uniform();
                    let u = rng.uniform2();
                    viewed.sample(u_lobe, u).map(|s| {
                        assert!(!s.delta);
                        s.wi
                    })
                },
                |wi| viewed.pdf(wi) as f64,
                NUM_CHI2_TESTS,
            );
            println!("{} wo={wo:?}: {result:?}", c.name);
            if let Err(e) = result {
                failures.push(e);
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn chi2_diffuse_layer() {
    chi2_family("diffuse");
}

#[test]
fn chi2_dielectric_specular() {
    chi2_family("dielectric");
}

#[test]
fn chi2_metal() {
    chi2_family("metal");
}

#[test]
fn chi2_rough_glass() {
    chi2_family("rough glass");
}

#[test]
fn chi2_mixtures() {
    chi2_family("mixture");
}

#[test]
fn chi2_coat() {
    chi2_family("coat");
}

#[test]
fn chi2_sheen() {
    chi2_family("sheen");
}

#[test]
fn chi2_anisotropic() {
    chi2_family("anisotropic");
}

#[test]
fn chi2_layered() {
    chi2_family("layered");
}

#[test]
fn chi2_translucent() {
    chi2_family("translucent");
}

#[test]
fn chi2_refraction() {
    chi2_family("refraction");
}

#[test]
fn chi2_thin_film() {
    chi2_family("thin film");
}

#[test]
fn chi2_rough_diffuse() {
    chi2_family("rough diffuse");
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6
}

#[test]
fn sample_weight_is_eval_over_pdf() {
    for c in rough_cases() {
        for wo in view_directions(c.inside) {
            let mut rng = Rng::new(5);
            let viewed = c.bsdf.viewed_from(wo);
            for _ in 0..5000 {
                let Some(s) = viewed.sample(rng.uniform(), rng.uniform2()) else {
                    continue;
                };
                let pdf = viewed.pdf(s.wi);
                let f = viewed.eval(s.wi);
                assert!(
                    close(pdf, s.pdf, 1e-3),
                    "{}: pdf {} vs {}",
                    c.name,
                    pdf,
                    s.pdf
                );
                let expected = f / pdf;
                for i in 0..3 {
                    assert!(
                        close(s.weight[i], expected[i], 1e-3),
                        "{}: weight {:?} vs eval/pdf {:?}",
                        c.name,
                        s.weight,
                        expected
                    );
                }
                assert_eq!(s.transmitted, s.wi.z * wo.z < 0.0);
            }
        }
    }
}

#[test]
fn opaque_lobes_stay_on_the_viewer_side() {
    let mut rng = Rng::new(6);
    for c in rough_cases()
        .into_iter()
        .filter(|c| !c.bsdf.is_transmissive())
    {
        for wo in view_directions(false) {
            let below = Vec3::new(wo.x, wo.y, -wo.z);
            for _ in 0..200 {
                let wi = photon::sampling::square_to_uniform_sphere(rng.uniform2());
                if wi.z < 0.0 {
                    assert_eq!(c.bsdf.viewed_from(wo).eval(wi), Vec3::ZERO, "{}", c.name);
                    assert_eq!(c.bsdf.viewed_from(wo).pdf(wi), 0.0, "{}", c.name);
                }
                assert_eq!(c.bsdf.viewed_from(below).eval(wi), Vec3::ZERO, "{}", c.name);
                assert_eq!(c.bsdf.viewed_from(below).pdf(wi), 0.0, "{}", c.name);
                assert!(c
                    .bsdf
                    .viewed_from(below)
                    .sample(rng.uniform(), rng.uniform2())
                    .is_none());
            }
        }
    }
    // Glass scatters from both sides, into both hemispheres.
    let glass = Bsdf::new(&material(Vec3::ONE, 0.0, 0.5, 1.0));
    for wo in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.6, 0.0, -0.8)] {
        let reflected = Vec3::new(-0.6, 0.0, wo.z);
        let refracted = Vec3::new(-0.3, 0.0, -wo.z.signum() * 0.95).normalize();
        assert!(glass.viewed_from(wo).eval(reflected).max_element() > 0.0);
        assert!(glass.viewed_from(wo).eval(refracted).max_element() > 0.0);
        assert!(glass.viewed_from(wo).pdf(refracted) > 0.0);
    }
}

#[test]
fn single_scattering_lobes_are_reciprocal() {
    // The Lambertian and the uncompensated (GGX) glass reflection are reciprocal. The layered
    // base and the compensated metal and glass (Multiscatter GGX) are not exactly, in Cycles as
    // here: their scaling depends on the view angle only.
    let diffuse = Bsdf::new(&SurfaceMaterial {
        specular: 0.0,
        ..material(Vec3::splat(0.7), 0.0, 0.5, 0.0)
    });
    let glass = Bsdf::new(&SurfaceMaterial {
        single_scatter: true,
        ..material(Vec3::ONE, 0.0, 0.4, 1.0)
    });
    let mut rng = Rng::new(7);
    // Lambertian transmission: f(wo, wi) = f(wi, wo) = colour / π across the surface.
    let colour = Vec3::new(0.9, 0.6, 0.3);
    let leaf = Bsdf::new(&translucent(colour));
    for _ in 0..2000 {
        let a = photon::sampling::square_to_uniform_sphere(rng.uniform2());
        let c = photon::sampling::square_to_uniform_sphere(rng.uniform2());
        if a.z.abs() < 1e-3 || c.z.abs() < 1e-3 {
            continue;
        }
        let f1 = leaf.viewed_from(a).eval(c) / c.z.abs();
        let f2 = leaf.viewed_from(c).eval(a) / a.z.abs();
        let expected = if a.z * c.z < 0.0 {
            colour / std::f32::consts::PI
        } else {
            Vec3::ZERO
        };
        assert!((f1 - expected).length() < 1e-5 && (f2 - expected).length() < 1e-5);
        let pdf = leaf.viewed_from(a).pdf(c);
        let want = if a.z * c.z < 0.0 {
            c.z.abs() / std::f32::consts::PI
        } else {
            0.0
        };
        assert!((pdf - want).abs() < 1e-5, "pdf {pdf} vs {want}");
    }
    for b in [diffuse, glass] {
        for _ in 0..2000 {
            let a = photon::sampling::square_to_cosine_hemisphere(rng.uniform2());
            let c = photon::sampling::square_to_cosine_hemisphere(rng.uniform2());
            if a.z < 1e-3 || c.z < 1e-3 {
                continue;
            }
            for side in [1.0f32, -1.0] {
                if side < 0.0 && !b.is_transmissive() {
                    continue;
                }
                let (wo, wi) = (
                    Vec3::new(a.x, a.y, a.z * side),
                    Vec3::new(c.x, c.y, c.z * side),
                );
                let f1 = b.viewed_from(wo).eval(wi) / wi.z.abs();
                let f2 = b.viewed_from(wi).eval(wo) / wo.z.abs();
                for i in 0..3 {
                    assert!(
                        close(f1[i], f2[i], 2e-3),
                        "{f1:?} vs {f2:?} at {wo:?} {wi:?}"
                    );
                }
            }
        }
    }
}

/// Directional albedo ∫ f |cos| dωi by Monte Carlo over `sample_bsdf` (delta samples included):
/// mean and standard error of the largest channel.
fn measured_albedo(b: &Bsdf, wo: Vec3, n: usize, seed: u64) -> (Vec3, f32) {
    let mut rng = Rng::new(seed);
    let (mut sum, mut sum2) = (Vec3::ZERO, 0.0f64);
    let viewed = b.viewed_from(wo);
    for _ in 0..n {
        if let Some(s) = viewed.sample(rng.uniform(), rng.uniform2()) {
            sum += s.weight;
            sum2 += (s.weight.max_element() as f64).powi(2);
        }
    }
    let mean = sum / n as f32;
    let var = (sum2 / n as f64 - (mean.max_element() as f64).powi(2)).max(0.0);
    (mean, (var / n as f64).sqrt() as f32)
}

fn view(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

#[test]
fn white_furnace_never_creates_energy() {
    let mut configs = Vec::new();
    for &metallic in &[0.0, 0.5, 1.0] {
        for &transmission in &[0.0, 0.5, 1.0] {
            for &roughness in &[0.0, 0.1, 0.3, 0.6, 1.0] {
                for &ior in &[1.0, 1.5, 3.0] {
                    configs.push(SurfaceMaterial {
                        ior,
                        ..material(Vec3::ONE, metallic, roughness, transmission)
                    });
                }
            }
        }
    }
    // Coats, sheens and anisotropy over white bases.
    for &metallic in &[0.0, 1.0] {
        for &roughness in &[0.0, 0.3, 1.0] {
            for &coat in &[0.0, 0.5, 1.0] {
                for &sheen in &[0.0, 1.0] {
                    for &aspect in &[1.0, 0.4] {
                        configs.push(SurfaceMaterial {
                            coat_weight: coat,
                            coat_roughness: 0.2,
                            sheen_weight: sheen,
                            sheen_roughness: 0.6,
                            aspect,
                            ..material(Vec3::ONE, metallic, roughness, 0.0)
                        });
                    }
                }
            }
        }
    }
    // Oren–Nayar diffuse, alone and under the specular layer and a coat.
    for &sigma in &[0.3, 1.0] {
        for &(specular, coat) in &[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)] {
            configs.push(SurfaceMaterial {
                specular,
                coat_weight: coat,
                diffuse_roughness: sigma,
                ..material(Vec3::ONE, 0.0, 0.5, 0.0)
            });
        }
    }
    configs.push(translucent(Vec3::ONE));
    configs.push(SurfaceMaterial {
        diffuse_transmission_color: Vec3::ONE,
        ..transmitting_base(Vec3::ONE, 0.4, 1.0)
    });
    // Thin films on the specular layer and the glass (Cycles 4.5's Principled Thin Film).
    for &thickness in &[250.0, 500.0, 800.0] {
        for &roughness in &[0.0, 0.3, 0.8] {
            for &transmission in &[0.0, 1.0] {
                configs.push(film(
                    material(Vec3::ONE, 0.0, roughness, transmission),
                    thickness,
                ));
            }
        }
    }
    for m in configs {
        let b = Bsdf::new(&m);
        for &mu in &[1.0, 0.6, 0.2, 0.05, -0.5, -0.1] {
            if mu < 0.0 && !b.is_transmissive() {
                continue;
            }
            let (albedo, err) = measured_albedo(&b, view(mu), 40_000, 8);
            // Cycles compensates anisotropic GGX with the isotropic tables at α = sqrt(α_x α_y):
            // a few per cent too much at grazing views along the rough axis, here as there.
            let bound = if m.aspect < 1.0 { 1.05 } else { 1.01 };
            assert!(
                albedo.max_element() <= bound + 4.0 * err,
                "albedo {albedo:?} ± {err} for {m:?} at μ = {mu}"
            );
        }
    }
}

#[test]
fn white_furnace_is_one_for_white_dielectric_and_metal() {
    let dielectric = Bsdf::new(&material(Vec3::ONE, 0.0, 0.5, 0.0));
    for &mu in &[0.1, 0.5, 1.0] {
        let (albedo, err) = measured_albedo(&dielectric, view(mu), 400_000, 9);
        println!(
            "white dielectric r=0.5 μ={mu}: {albedo:?} ± {err}, estimate {:?}",
            dielectric.viewed_from(view(mu)).albedo()
        );
        assert!(
            (albedo.max_element() - 1.0).abs() < 0.025,
            "dielectric μ={mu}: {albedo:?}"
        );
    }
    // Oren–Nayar diffuse with its multiple scattering: white reflects all the light (a grey
    // one less than Lambert's ρ at normal view, as its single scattering darkens there).
    for &sigma in &[0.5, 1.0] {
        let rough = |rho: f32| {
            Bsdf::new(&SurfaceMaterial {
                specular: 0.0,
                diffuse_roughness: sigma,
                ..material(Vec3::splat(rho), 0.0, 0.5, 0.0)
            })
        };
        for &mu in &[0.1, 0.5, 1.0] {
            let (albedo, err) = measured_albedo(&rough(1.0), view(mu), 400_000, 11);
            println!("white Oren–Nayar σ={sigma} μ={mu}: {albedo:?} ± {err}");
            assert!(
                (albedo.max_element() - 1.0).abs() < 4.0 * err + 1e-3,
                "Oren–Nayar σ={sigma} μ={mu}: {albedo:?} ± {err}"
            );
            let (grey, err) = measured_albedo(&rough(0.5), view(mu), 400_000, 12);
            let estimate = rough(0.5).viewed_from(view(mu)).albedo();
            assert!(
                (grey.x - estimate.x).abs() < 4.0 * err + 1e-3 && grey.x < 0.5,
                "grey Oren–Nayar σ={sigma} μ={mu}: {grey:?} ± {err} vs {estimate:?}"
            );
        }
    }
    for &r in &[0.5, 1.0] {
        let metal = Bsdf::new(&material(Vec3::ONE, 1.0, r, 0.0));
        for &mu in &[0.1, 0.5, 1.0] {
            let (albedo, err) = measured_albedo(&metal, view(mu), 400_000, 10);
            println!("white metal r={r} μ={mu}: {albedo:?} ± {err}");
            assert!(
                (albedo.max_element() - 1.0).abs() < 0.025,
                "metal r={r} μ={mu}: {albedo:?}"
            );
        }
    }
}

#[test]
fn single_scatter_ggx_loses_what_multiscatter_ggx_gives_back() {
    // Blender's GGX distribution (no energy compensation): a white rough metal reflects the
    // single-scattering albedo E(μ) < 1 where Multiscatter GGX reflects 1, and the lobe's own
    // albedo estimate (what layering and light choice read) agrees with its samples; on a
    // white dielectric the diffuse takes what the uncompensated specular layer leaves.
    for &r in &[0.5, 1.0] {
        let multi = material(Vec3::ONE, 1.0, r, 0.0);
        let single = SurfaceMaterial {
            single_scatter: true,
            ..multi
        };
        for &mu in &[0.2, 0.6, 1.0] {
            let (full, _) = measured_albedo(&Bsdf::new(&multi), view(mu), 200_000, 21);
            let b = Bsdf::new(&single);
            let (lossy, err) = measured_albedo(&b, view(mu), 200_000, 21);
            let estimate = b.viewed_from(view(mu)).albedo();
            println!("white metal r={r} μ={mu}: single {lossy:?} ± {err}, estimate {estimate:?}, multi {full:?}");
            assert!(
                lossy.x < full.x - 0.02 && lossy.x > 0.3,
                "r={r} μ={mu}: single {lossy:?}, multi {full:?}"
            );
            assert!(
                (lossy.x - estimate.x).abs() < 4.0 * err + 2e-3,
                "r={r} μ={mu}: sampled {lossy:?} ± {err}, estimate {estimate:?}"
            );
        }
    }
    let dielectric = SurfaceMaterial {
        single_scatter: true,
        ..material(Vec3::ONE, 0.0, 1.0, 0.0)
    };
    for &mu in &[0.2, 1.0] {
        let (albedo, err) = measured_albedo(&Bsdf::new(&dielectric), view(mu), 200_000, 22);
        assert!(
            (albedo.max_element() - 1.0).abs() < 0.025 + 4.0 * err,
            "white GGX dielectric μ={mu}: {albedo:?} ± {err}"
        );
    }
}

#[test]
fn multiscatter_glass_loses_nothing() {
    // White rough glass in Multiscatter GGX (the default) is divided by its single-scattering
    // albedo: reflection plus refraction sum to 1 from either side; in GGX it loses energy.
    for &r in &[0.3, 0.7, 1.0] {
        let multi = material(Vec3::ONE, 0.0, r, 1.0);
        let single = SurfaceMaterial {
            single_scatter: true,
            ..multi
        };
        for &mu in &[0.9, 0.4, -0.4, -0.9] {
            let (albedo, err) = measured_albedo(&Bsdf::new(&multi), view(mu), 100_000, 23);
            let (lossy, _) = measured_albedo(&Bsdf::new(&single), view(mu), 100_000, 23);
            println!("white glass r={r} μ={mu}: multiscatter {albedo:?} ± {err}, GGX {lossy:?}");
            assert!(
                (albedo.x - 1.0).abs() < 0.015 + 4.0 * err,
                "r={r} μ={mu}: {albedo:?} ± {err}"
            );
            assert!(lossy.x < albedo.x, "r={r} μ={mu}: {lossy:?} vs {albedo:?}");
        }
    }
}

#[test]
fn translucent_transmits_its_colour_and_reflects_nothing() {
    // White furnace: a white Translucent BSDF sends all the light through, from either side,
    // by cosine-weighted samples of weight exactly its colour; nothing is reflected.
    let colour = Vec3::new(0.9, 0.6, 0.3);
    for c in [Vec3::ONE, colour] {
        let b = Bsdf::new(&translucent(c));
        assert!(b.is_transmissive() && b.has_non_delta() && !b.has_delta());
        for &mu in &[1.0, 0.5, 0.1, -0.3, -0.9] {
            let wo = view(mu);
            let v = b.viewed_from(wo);
            assert_eq!(v.diffuse_reflectance(), Vec3::ZERO);
            assert!((v.albedo() - c).length() < 1e-6);
            let mut rng = Rng::new(13);
            for _ in 0..2000 {
                let s = v
                    .sample(rng.uniform(), rng.uniform2())
                    .expect("always samples");
                assert!(s.transmitted && s.wi.z * wo.z < 0.0 && !s.delta);
                assert!((s.weight - c).length() < 1e-5, "{:?}", s.weight);
                assert_eq!(s.scattering, photon::bsdf::Scattering::Diffuse);
            }
        }
    }
}

#[test]
fn smooth_glass_splits_by_fresnel() {
    let glass = Bsdf::new(&material(Vec3::ONE, 0.0, 0.0, 1.0));
    assert!(glass.is_delta_only());
    for &mu in &[1.0f32, 0.7, 0.3, 0.05, -0.9, -0.8, -0.5] {
        let wo = view(mu.abs()) * Vec3::new(1.0, 1.0, mu.signum());
        let eta = if mu > 0.0 { 1.5 } else { 1.0 / 1.5 };
        let fresnel = fresnel_dielectric(mu.abs(), eta);
        let mut rng = Rng::new(11);
        let n = 100_000;
        let mut reflected = 0;
        for _ in 0..n {
            let s = glass
                .viewed_from(wo)
                .sample(rng.uniform(), rng.uniform2())
                .expect("glass always scatters");
            assert!(s.delta);
            assert!(
                (s.weight - Vec3::ONE).length() < 1e-4,
                "weight {:?}",
                s.weight
            );
            let p = if s.transmitted {
                1.0 - fresnel
            } else {
                fresnel
            };
            assert!((s.pdf - p).abs() < 1e-5, "pdf {} vs {p}", s.pdf);
            if !s.transmitted {
                reflected += 1;
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-5);
            } else {
                // Snell's law.
                let sin_o = (1.0 - wo.z * wo.z).sqrt();
                let sin_i = (1.0 - s.wi.z * s.wi.z).sqrt();
                assert!((sin_o - eta * sin_i).abs() < 1e-4);
            }
        }
        let frac = reflected as f32 / n as f32;
        let sigma = (fresnel * (1.0 - fresnel) / n as f32).sqrt();
        assert!(
            (frac - fresnel).abs() <= 5.0 * sigma + 1e-6,
            "μ={mu}: {frac} vs F = {fresnel}"
        );
    }
}

#[test]
fn extreme_inputs_give_finite_values() {
    let mut rng = Rng::new(12);
    let mut checked = 0;
    for &roughness in &[0.0, 1e-4, 0.019, 0.021, 0.5, 1.0] {
        for &ior in &[1.0, 1.00001, 1.5, 10.0, 0.5] {
            for &metallic in &[0.0, 0.5, 1.0] {
                for &transmission in &[0.0, 0.5, 1.0] {
                    for &base in &[0.0, 1.0, 5.0] {
                        for &specular in &[0.0, 1.0, 3.0] {
                            let m = SurfaceMaterial {
                                ior,
                                specular,
                                ..material(Vec3::splat(base), metallic, roughness, transmission)
                            };
                            let b = Bsdf::new(&m);
                            for &z in &[1e-6f32, -1e-6, 0.0, 0.3, 1.0, -1.0] {
                                let wo = Vec3::new((1.0 - z * z).max(0.0).sqrt(), 0.0, z);
                                let wi = photon::sampling::square_to_uniform_sphere(rng.uniform2());
                                assert!(b.viewed_from(wo).eval(wi).is_finite(), "{m:?}");
                                assert!(b.viewed_from(wo).pdf(wi).is_finite(), "{m:?}");
                                assert!(b.viewed_from(wo).albedo().is_finite(), "{m:?}");
                                assert!(b.viewed_from(wo).diffuse_reflectance().is_finite());
                                for _ in 0..20 {
                                    if let Some(s) =
                                        b.viewed_from(wo).sample(rng.uniform(), rng.uniform2())
                                    {
                                        assert!(
                                            s.weight.is_finite() && s.wi.is_finite(),
                                            "{m:?} {s:?}"
                                        );
                                        assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{m:?} {s:?}");
                                        assert!((s.wi.length() - 1.0).abs() < 1e-3, "{m:?} {s:?}");
                                    }
                                }
                                checked += 1;
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 1000);
}

#[test]
fn flags_describe_the_lobes() {
    let smooth_metal = Bsdf::new(&material(Vec3::ONE, 1.0, 0.0, 0.0));
    assert!(
        smooth_metal.is_delta_only() && smooth_metal.has_delta() && !smooth_metal.is_transmissive()
    );
    let rough_metal = Bsdf::new(&material(Vec3::ONE, 1.0, 0.5, 0.0));
    assert!(rough_metal.has_non_delta() && !rough_metal.has_delta());
    let plastic = Bsdf::new(&material(Vec3::ONE, 0.0, 0.0, 0.0));
    assert!(plastic.has_non_delta() && plastic.has_delta());
    let glass = Bsdf::new(&material(Vec3::ONE, 0.0, 0.3, 1.0));
    assert!(glass.is_transmissive() && glass.has_non_delta());
    // The diffuse part shrinks where the specular layer reflects more.
    let grey = Bsdf::new(&material(Vec3::splat(0.5), 0.0, 0.5, 0.0));
    assert!(
        grey.viewed_from(view(0.1)).diffuse_reflectance().x
            < grey.viewed_from(view(1.0)).diffuse_reflectance().x
    );
    assert!(grey.viewed_from(view(1.0)).diffuse_reflectance().x < 0.5);
}

/// The sheen alone reflects its tint × the layer's albedo R(μ), which its directional albedo
/// estimate states, and its samples carry exactly that.
#[test]
fn sheen_reflects_its_albedo() {
    for &r in &[0.1f32, 0.5, 1.0] {
        let m = SurfaceMaterial {
            specular: 0.0,
            sheen_weight: 1.0,
            sheen_roughness: r,
            sheen_tint: Vec3::new(1.0, 0.5, 0.25),
            ..material(Vec3::ZERO, 0.0, 0.5, 0.0)
        };
        let b = Bsdf::new(&m);
        for &mu in &[0.1f32, 0.5, 0.95] {
            let expected = photon::bsdf::sheen::SheenLobe::new(mu, r).albedo;
            let estimate = b.viewed_from(view(mu)).albedo();
            assert!(
                (estimate - Vec3::new(1.0, 0.5, 0.25) * expected).length() < 1e-5,
                "{estimate:?} vs {expected}"
            );
            let (measured, err) = measured_albedo(&b, view(mu), 50_000, 13);
            assert!(
                (measured.x - expected).abs() < 1e-3 + 4.0 * err,
                "sheen r={r} μ={mu}: {measured:?} vs {expected}"
            );
            assert!(
                expected > 0.0 && expected < 0.8,
                "R({mu}, {r}) = {expected}"
            );
        }
    }
    // Retro-reflective at grazing views: light from near the viewer's side is brighter than
    // light from the mirror direction.
    let b = Bsdf::new(&SurfaceMaterial {
        specular: 0.0,
        sheen_weight: 1.0,
        sheen_roughness: 0.5,
        ..material(Vec3::ZERO, 0.0, 0.5, 0.0)
    });
    let wo = view(0.2);
    let back = Vec3::new(0.9, 0.1, 0.3).normalize();
    let mirror = Vec3::new(-0.9, 0.1, 0.3).normalize();
    let v = b.viewed_from(wo);
    assert!(
        v.eval(back).x > v.eval(mirror).x,
        "{:?} {:?}",
        v.eval(back),
        v.eval(mirror)
    );
}

/// Layering as Cycles: a coat scales what lies below by 1 − its albedo and tints it by
/// tint^(1/cos θt); a sheen scales it by 1 − max(its albedo); the base's emission factor is
/// the same.
#[test]
fn layers_attenuate_the_base() {
    let red = material(Vec3::new(0.8, 0.2, 0.1), 0.0, 0.5, 0.0);
    let plain = Bsdf::new(&red).viewed_from(Vec3::Z);
    let coated_bsdf = Bsdf::new(&SurfaceMaterial {
        coat_weight: 1.0,
        coat_roughness: 0.0,
        ..red
    });
    let coated = coated_bsdf.viewed_from(Vec3::Z);
    // A smooth coat of IOR 1.5 seen head-on reflects 4 %.
    let f = 0.04f32;
    assert!(coated_bsdf.has_delta());
    assert!((coated.layer_transmittance() - Vec3::splat(1.0 - f)).length() < 1e-4);
    let ratio = coated.diffuse_reflectance() / plain.diffuse_reflectance();
    assert!((ratio - Vec3::splat(1.0 - f)).length() < 1e-4, "{ratio:?}");
    // Head-on, the tint is applied once; half a coat weight mixes it halfway.
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let tinted = Bsdf::new(&SurfaceMaterial {
        coat_weight: 0.5,
        coat_roughness: 0.0,
        coat_tint: tint,
        ..red
    })
    .viewed_from(Vec3::Z);
    let expected = (Vec3::ONE + tint) * 0.5 * (1.0 - 0.5 * f);
    assert!(
        (tinted.layer_transmittance() - expected).length() < 1e-4,
        "{:?} vs {expected:?}",
        tinted.layer_transmittance()
    );
    // Seen obliquely, the tint's path through the coat is longer.
    let oblique = Bsdf::new(&SurfaceMaterial {
        coat_weight: 1.0,
        coat_roughness: 0.0,
        coat_tint: tint,
        ..red
    })
    .viewed_from(view(0.3));
    let cos_t = (1.0f32 - (1.0 - 0.09) / 2.25).sqrt();
    let through = tint.y.powf(1.0 / cos_t);
    let expected_g = through * (1.0 - fresnel_dielectric(0.3, 1.5));
    assert!((oblique.layer_transmittance().y - expected_g).abs() < 1e-4);
    // A sheen of albedo R above: the base keeps 1 − R.
    let sheened = Bsdf::new(&SurfaceMaterial {
        sheen_weight: 1.0,
        sheen_roughness: 0.5,
        ..red
    })
    .viewed_from(view(0.5));
    let r = photon::bsdf::sheen::SheenLobe::new(0.5, 0.5).albedo;
    let base = Bsdf::new(&red).viewed_from(view(0.5)).diffuse_reflectance();
    assert!((sheened.diffuse_reflectance() - base * (1.0 - r)).length() < 1e-5);
}

/// The anisotropic lobe is wider along the tangent (x) than along the bitangent, by the
/// aspect ratio, and isotropic at aspect 1.
#[test]
fn anisotropy_stretches_the_highlight_along_the_tangent() {
    let m = material(Vec3::ONE, 1.0, 0.3, 0.0);
    let iso = Bsdf::new(&m).viewed_from(Vec3::Z);
    let aniso = Bsdf::new(&SurfaceMaterial { aspect: 0.5, ..m }).viewed_from(Vec3::Z);
    let along_x = Vec3::new(0.3, 0.0, 1.0).normalize();
    let along_y = Vec3::new(0.0, 0.3, 1.0).normalize();
    assert!((iso.eval(along_x) - iso.eval(along_y)).length() < 1e-4);
    assert!(aniso.eval(along_x).x > 2.0 * aniso.eval(along_y).x);
    // About the same energy: the compensation uses the isotropic tables at α = sqrt(α_x α_y),
    // as Cycles does (head-on, 1.3 % apart).
    let (a_iso, e1) = measured_albedo(&Bsdf::new(&m), Vec3::Z, 200_000, 14);
    let (a_aniso, e2) = measured_albedo(
        &Bsdf::new(&SurfaceMaterial { aspect: 0.5, ..m }),
        Vec3::Z,
        200_000,
        15,
    );
    assert!(
        (a_iso.x - a_aniso.x).abs() < 0.02 + 4.0 * (e1 + e2),
        "{a_iso:?} {a_aniso:?}"
    );
}

#[test]
fn weight_scales_values_and_samples_not_densities() {
    // A node tree's Add Shader doubles the BSDF it picks: every value and sample weight twice
    // the unweighted one, the same densities and directions.
    let plain = material(Vec3::new(0.6, 0.3, 0.2), 0.4, 0.5, 0.0);
    let doubled = SurfaceMaterial {
        weight: 2.0,
        ..plain
    };
    let (a, b) = (Bsdf::new(&plain), Bsdf::new(&doubled));
    for &mu in &[1.0, 0.6, 0.2] {
        let wo = view(mu);
        let (va, vb) = (a.viewed_from(wo), b.viewed_from(wo));
        assert!((vb.albedo() - 2.0 * va.albedo()).length() < 1e-6);
        assert!((vb.diffuse_reflectance() - 2.0 * va.diffuse_reflectance()).length() < 1e-6);
        assert!((vb.base_transmittance() - 2.0 * va.base_transmittance()).abs() < 1e-6);
        let mut rng = Rng::new(29);
        for _ in 0..500 {
            let (u, uu) = (rng.uniform(), rng.uniform2());
            let (Some(sa), Some(sb)) = (va.sample(u, uu), vb.sample(u, uu)) else {
                continue;
            };
            assert_eq!(sa.wi, sb.wi);
            assert_eq!(sa.pdf, sb.pdf);
            assert!((sb.weight - 2.0 * sa.weight).length() <= 1e-5 * sa.weight.length());
            let ((fa, pa), (fb, pb)) = (va.eval_and_pdf(sa.wi), vb.eval_and_pdf(sa.wi));
            assert_eq!(pa, pb);
            assert!((fb - 2.0 * fa).length() <= 1e-5 * fa.length().max(1e-12));
        }
    }
}

#[test]
fn refraction_transmits_its_colour_without_fresnel() {
    // Smooth: every sample crosses with weight exactly the colour, from outside and from
    // inside below the critical angle; past it (inside, grazing) nothing leaves. Rough: nothing
    // is reflected, nothing is created, and the transmitted BTDF obeys reciprocity with the
    // η² factor of refraction, f(wo, wi) / η_i² = f(wi, wo) / η_o².
    let colour = Vec3::new(0.9, 0.6, 0.3);
    let smooth = Bsdf::new(&refraction(colour, 0.0));
    assert!(smooth.is_delta_only() && smooth.is_transmissive());
    let mut rng = Rng::new(17);
    for &mu in &[1.0f32, 0.6, 0.2, -1.0, -0.9, -0.8, -0.5, -0.2] {
        let wo = view(mu.abs()) * Vec3::new(1.0, 1.0, mu.signum());
        let critical = mu < 0.0 && (1.0 - mu * mu) * 1.5 * 1.5 >= 1.0;
        for _ in 0..200 {
            match smooth.viewed_from(wo).sample(rng.uniform(), rng.uniform2()) {
                Some(s) if s.weight != Vec3::ZERO => {
                    assert!(!critical, "light left past the critical angle at {mu}");
                    assert!(s.transmitted && s.delta, "{s:?}");
                    assert!((s.weight - colour).length() < 1e-5, "{:?}", s.weight);
                }
                _ => assert!(critical, "nothing crossed at {mu}"),
            }
        }
    }
    let rough = Bsdf::new(&refraction(Vec3::ONE, 0.4));
    for &mu in &[0.9f32, 0.5, 0.15] {
        let v = rough.viewed_from(view(mu));
        let (albedo, error) = measured_albedo(&rough, view(mu), 200_000, 5);
        assert!(
            albedo.x < 1.0 + 4.0 * error,
            "albedo {albedo:?} ± {error} at {mu}"
        );
        assert!(albedo.x > 0.8, "albedo {albedo:?} at {mu}");
        for _ in 0..500 {
            let wi = photon::sampling::square_to_uniform_sphere(rng.uniform2());
            if wi.z > 0.0 {
                assert_eq!(v.eval(wi), Vec3::ZERO, "reflected towards {wi:?}");
            }
        }
    }
    let eta = 1.5f32;
    for _ in 0..2000 {
        let a = photon::sampling::square_to_cosine_hemisphere(rng.uniform2());
        let c = photon::sampling::square_to_cosine_hemisphere(rng.uniform2());
        if a.z < 1e-2 || c.z < 1e-2 {
            continue;
        }
        let (wo, wi) = (a, Vec3::new(c.x, c.y, -c.z));
        let f1 = rough.viewed_from(wo).eval(wi).x / wi.z.abs();
        let f2 = rough.viewed_from(wi).eval(wo).x / wo.z.abs();
        // wo outside (η_o = 1), wi inside (η_i = η).
        assert!(
            close(f1 / (eta * eta), f2, 2e-3),
            "{f1} / η² vs {f2} at {wo:?} {wi:?}"
        );
    }
}

/// A smooth specular layer under a thin film (black base: the layer alone) reflects what
/// Blender 4.5's Cycles renders for it (a mirror plane under a white world, seen straight on
/// and at 60° by an orthographic camera; docs/bench/materials_vs_cycles.md, "Thin film"),
/// with its Specular IOR Level and Tint, a film under 30 nm and an IOR below 1.
#[test]
fn thin_film_layer_matches_cycles() {
    let cases = [
        // (thickness, level, tint, IOR, view angle, Cycles' RGB)
        (
            500.0,
            0.5,
            Vec3::ONE,
            1.5,
            0.0,
            [0.037087, 0.008976, 0.036142],
        ),
        (
            500.0,
            0.5,
            Vec3::ONE,
            1.5,
            60.0,
            [0.031311, 0.082435, 0.064725],
        ),
        (
            500.0,
            0.25,
            Vec3::new(1.0, 0.5, 0.2),
            1.5,
            0.0,
            [0.020011, 0.010057, 0.004003],
        ),
        (
            500.0,
            0.8,
            Vec3::ONE,
            1.5,
            0.0,
            [0.058874, 0.005114, 0.056868],
        ),
        (
            15.0,
            0.5,
            Vec3::ONE,
            1.5,
            0.0,
            [0.039087, 0.038547, 0.037827],
        ),
        (
            15.0,
            0.5,
            Vec3::ONE,
            1.5,
            60.0,
            [0.088416, 0.087936, 0.087333],
        ),
        (
            500.0,
            0.5,
            Vec3::ONE,
            0.8,
            0.0,
            [0.028667, 0.135773, 0.029999],
        ),
    ];
    for (thickness, level, tint, ior, angle, cycles) in cases {
        let m = SurfaceMaterial {
            ior,
            specular: 1.0,
            specular_color: 2.0 * level * tint,
            thin_film_thickness: thickness,
            thin_film_ior: 1.33,
            ..material(Vec3::ZERO, 0.0, 0.0, 0.0)
        };
        let s = Bsdf::new(&m)
            .viewed_from(view((angle as f32).to_radians().cos()))
            .sample(0.5, photon::math::Vec2::new(0.5, 0.5))
            .unwrap();
        assert!(s.delta);
        let want = Vec3::from(cycles);
        assert!(
            (s.weight - want).abs().max_element() < 3e-4,
            "{thickness} nm, level {level}, IOR {ior}, {angle}°: {} vs {want}",
            s.weight
        );
    }
}
