//! The photon map on its own: the left-balanced kd-tree's k-nearest and filtered nearest searches
//! against brute force on random and clustered points, and the compact photon's RGBE power and (θ, φ) direction
//! packing with their error bounds.

use photon::math::Vec3;
use photon::photon_map::{
    decode_direction, decode_rgbe, encode_direction, encode_rgbe, Neighbors, Photon, PhotonMap,
};
use photon::rng::Rng;

fn random_points(n: usize, clustered: bool, rng: &mut Rng) -> Vec<Vec3> {
    let centres: Vec<Vec3> = (0..8)
        .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0)
        .collect();
    (0..n)
        .map(|i| {
            let u = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            if clustered {
                // Tight clusters, a flat one among them, plus duplicates.
                let c = centres[i % centres.len()];
                let spread = if i % 8 == 3 {
                    Vec3::new(1.0, 0.0, 1.0)
                } else {
                    Vec3::splat(0.05)
                };
                if i % 50 == 0 {
                    c
                } else {
                    c + (u - 0.5) * spread
                }
            } else {
                u * Vec3::new(10.0, 2.0, 5.0)
            }
        })
        .collect()
}

fn check_against_brute_force(clustered: bool) {
    let mut rng = Rng::new(if clustered { 11 } else { 5 });
    let points = random_points(4000, clustered, &mut rng);
    let photons: Vec<Photon> = points
        .iter()
        .map(|&p| Photon::new(p, Vec3::ONE, Vec3::Z, 1, false))
        .collect();
    let map = PhotonMap::build(photons);
    assert_eq!(map.len(), points.len());
    let mut buf = Neighbors::default();
    for q in 0..300 {
        let p = if q % 2 == 0 {
            points[rng.below(points.len() as u32) as usize] + Vec3::splat(0.01)
        } else {
            Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0
        };
        let k = [1, 8, 50, 200][q % 4];
        let max_d2 = [0.01f32, 0.5, 4.0, f32::INFINITY][(q / 4) % 4];
        map.nearest(p, k, max_d2, &mut buf);
        let mut found: Vec<f32> = buf.iter().map(|n| n.dist2).collect();
        found.sort_by(f32::total_cmp);
        for n in buf.iter() {
            let d2 = (map.photons()[n.index as usize].position() - p).length_squared();
            assert_eq!(d2, n.dist2);
        }
        let mut all: Vec<f32> = map
            .photons()
            .iter()
            .map(|ph| (ph.position() - p).length_squared())
            .filter(|&d2| d2 < max_d2)
            .collect();
        all.sort_by(f32::total_cmp);
        all.truncate(k);
        assert_eq!(found, all, "query {q}: k {k}, max {max_d2}");
        assert_eq!(buf.is_full(), all.len() == k);

        // The filtered single-nearest search: photons in the upper half-space only.
        let accept = |ph: &Photon, _: f32| ph.position().y > 1.0;
        let accepted = map.nearest_accepted(p, max_d2, accept).map(|(_, d2)| d2);
        let expected = map
            .photons()
            .iter()
            .filter(|ph| accept(ph, 0.0))
            .map(|ph| (ph.position() - p).length_squared())
            .filter(|&d2| d2 < max_d2)
            .min_by(f32::total_cmp);
        assert_eq!(accepted, expected, "filtered query {q}: max {max_d2}");
    }
}

#[test]
fn knn_matches_brute_force_on_random_points() {
    check_against_brute_force(false);
}

#[test]
fn knn_matches_brute_force_on_clustered_points() {
    check_against_brute_force(true);
}

#[test]
fn empty_and_tiny_maps() {
    let mut buf = Neighbors::default();
    PhotonMap::build(Vec::new()).nearest(Vec3::ZERO, 5, 1.0, &mut buf);
    assert!(buf.is_empty());
    for n in 1..20 {
        let photons = (0..n)
            .map(|i| Photon::new(Vec3::splat(i as f32), Vec3::ONE, Vec3::Z, 0, false))
            .collect();
        let map = PhotonMap::build(photons);
        map.nearest(Vec3::ZERO, n, f32::INFINITY, &mut buf);
        assert_eq!(buf.len(), n);
    }
}

#[test]
fn rgbe_round_trip_error_is_below_one_part_in_256_of_the_largest_component() {
    let mut rng = Rng::new(3);
    for i in 0..20000 {
        let scale = 10f32.powf(rng.uniform() * 30.0 - 15.0);
        let mut c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * scale;
        if i % 7 == 0 {
            c.y = 0.0;
        }
        let d = decode_rgbe(encode_rgbe(c));
        let err = (d - c).abs().max_element();
        assert!(err <= c.max_element() / 256.0 * 1.0001, "{c:?} -> {d:?}");
    }
    assert_eq!(decode_rgbe(encode_rgbe(Vec3::ZERO)), Vec3::ZERO);
    assert_eq!(decode_rgbe(encode_rgbe(Vec3::splat(f32::NAN))), Vec3::ZERO);
}

#[test]
fn direction_packing_error_is_below_fourteen_milliradians() {
    let mut rng = Rng::new(4);
    let mut worst = 0.0f32;
    for _ in 0..20000 {
        let u = rng.uniform2();
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * u.y;
        let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let (t, p) = encode_direction(d);
        let e = decode_direction(t, p);
        assert!((e.length() - 1.0).abs() < 1e-5);
        worst = worst.max(e.dot(d).clamp(-1.0, 1.0).acos());
    }
    assert!(worst < 0.0140, "worst angular error {worst}");
    let ph = Photon::new(Vec3::ONE, Vec3::new(1.0, 2.0, 3.0), -Vec3::Z, 3, true);
    assert!(ph.incoming().dot(-Vec3::Z) > 0.9999);
    assert!(ph.is_caustic() && !ph.is_direct() && ph.bounces() == 3);
    let n = Vec3::new(0.6, 0.0, 0.8);
    assert!(ph.normal().dot(-Vec3::Z) > 0.9999);
    assert!(ph.with_normal(n).normal().dot(n) > 0.9999);
    assert_eq!(std::mem::size_of::<Photon>(), 24);
}
