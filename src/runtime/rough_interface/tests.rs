//! The interface integrals against Mitsuba's own tables, the smooth limit,
//! the grid's blend against the integrals, and the agreement of the native
//! with the table lowering reads.

use super::integrals::{GaussLegendre, node_cos};
use super::*;

/// Polypropylene in air, Mitsuba's defaults.
const ETA: f32 = 1.49 / 1.000277;

/// Mitsuba 3.9.1's `roughplastic` tables for ETA, read back from its
/// diffuse `eval` (scalar_rgb): (GGX, alpha, internal reflectance,
/// transmittance at the nodes 1, 16, 32, 48 and 63).
const MITSUBA: [(bool, f32, f32, [f32; 5]); 6] = [
    (false, 0.001, 0.57904, [0.08801, 0.74287, 0.91505, 0.95541, 0.96133]),
    (false, 0.1, 0.57466, [0.39238, 0.74927, 0.91335, 0.95486, 0.96132]),
    (false, 0.4, 0.48205, [0.75060, 0.83770, 0.90450, 0.94647, 0.96068]),
    (true, 0.001, 0.57913, [0.08901, 0.74287, 0.91505, 0.95541, 0.96133]),
    (true, 0.1, 0.54552, [0.57051, 0.76927, 0.91063, 0.95258, 0.96089]),
    (true, 0.4, 0.34247, [0.59868, 0.77335, 0.87046, 0.92402, 0.94891]),
];

fn table(t: &RoughInterface) -> [f32; ROUGH_INTERFACE_NODES] {
    t.transmittance
}

#[test]
fn the_tables_are_mitsubas() {
    for (ggx, alpha, r, ts) in MITSUBA {
        let t = &RoughInterface::integrate(alpha, ETA, ggx);
        let what = format!("ggx {ggx} alpha {alpha}");
        assert!((t.internal_reflectance - r).abs() < 5e-4, "{what}: {} against {r}", t.internal_reflectance);
        for (k, want) in [1, 16, 32, 48, 63].into_iter().zip(ts) {
            let got = table(t)[k];
            assert!((got - want).abs() < 5e-4, "{what}: T at node {k} is {got}, Mitsuba's {want}");
        }
    }
}

/// The dielectric Fresnel term of a smooth interface, from the textbook.
fn smooth_fresnel(cos_i: f64, eta: f64) -> f64 {
    let sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn a_nearly_smooth_interface_is_fresnels() {
    for ggx in [false, true] {
        for eta in [1.33f32, 1.5, 2.4] {
            let t = &RoughInterface::integrate(1e-4, eta, ggx);
            let e = f64::from(eta);
            // Away from grazing, where even a tiny roughness matters.
            for (k, got) in table(t).into_iter().enumerate().skip(8) {
                let want = 1.0 - smooth_fresnel(node_cos(k), e);
                assert!((f64::from(got) - want).abs() < 1e-3, "eta {eta}, node {k}: {got} against {want}");
            }
            // The same hemispherical rule over the smooth Fresnel term seen
            // from inside.
            let want = 2.0
                * (0..ROUGH_INTERFACE_NODES).map(|k| smooth_fresnel(node_cos(k), 1.0 / e) * node_cos(k)).sum::<f64>()
                / ROUGH_INTERFACE_NODES as f64;
            let got = f64::from(t.internal_reflectance);
            assert!((got - want).abs() < 2e-3, "eta {eta}: internal reflectance {got} against {want}");
        }
    }
}

#[test]
fn no_interface_lets_through_or_reflects_more_than_it_receives() {
    for ggx in [false, true] {
        for alpha in [1e-4f32, 0.05, 0.3, 1.0, 4.0] {
            for eta in [1.0 / 16.0, 0.7, 1.01, 1.5, 3.0, 16.0] {
                let t = &RoughInterface::integrate(alpha, eta, ggx);
                let what = format!("ggx {ggx} alpha {alpha} eta {eta}");
                assert!(table(t).iter().all(|x| (0.0..=1.0).contains(x)), "{what}: {:?}", table(t));
                assert!((0.0..=1.0).contains(&t.internal_reflectance), "{what}: {}", t.internal_reflectance);
            }
        }
        // A matched index reflects nothing and lets everything through
        // head-on; toward grazing, masking (single scattering) takes its
        // share, and Walter's fit of Beckmann's masking overshoots 1 by
        // its 1e-4 error where it nearly vanishes.
        let t = &RoughInterface::integrate(0.3, 1.0, ggx);
        assert!(table(t).iter().all(|x| (0.0..=1.0001).contains(x)), "{:?}", table(t));
        assert!((table(t)[63] - 1.0).abs() < 1e-6, "{:?}", table(t));
        assert!(t.internal_reflectance.abs() < 1e-6);
    }
}

#[test]
fn gauss_legendre_integrates_polynomials_exactly() {
    for n in [32, 128] {
        let rule = GaussLegendre::new(n);
        for degree in [0, 1, 7, 2 * n as i32 - 1] {
            let sum: f64 = rule.nodes.iter().zip(&rule.weights).map(|(x, w)| w * x.powi(degree)).sum();
            let want = 1.0 / f64::from(degree + 1);
            assert!((sum - want).abs() < 1e-12, "{n} nodes, x^{degree}: {sum} against {want}");
        }
    }
}

#[test]
fn the_grid_blends_close_to_the_integrals() {
    // Cell middles, where a bilinear blend errs most: Mitsuba's cases, a
    // wide roughness range and the indices of water, glass and diamond.
    // The internal reflectance of a nearly smooth interface is the least
    // smooth in the index (the mean over 64 angles of a reflectance with a
    // square-root kink at the critical angle), so it gets 2.5e-3.
    for ggx in [false, true] {
        for alpha_log2 in [-9.9375f32, -5.0625, -3.3125, -1.3125, -0.0625] {
            for eta in [1.3333f32, ETA, 2.4] {
                let alpha = alpha_log2.exp2();
                let exact = RoughInterface::integrate(alpha, eta, ggx);
                let point = GridPoint::new(alpha, eta, ggx).unwrap();
                let what = format!("ggx {ggx} alpha {alpha} eta {eta}");
                for k in 0..ROUGH_INTERFACE_NODES {
                    let (got, want) = (point.transmittance_node(k), exact.transmittance[k]);
                    assert!((got - want).abs() < 1e-3, "{what}: T at node {k} blends to {got}, integral {want}");
                }
                let (got, want) = (point.internal_reflectance(), exact.internal_reflectance);
                assert!((got - want).abs() < 2.5e-3, "{what}: internal reflectance blends to {got}, integral {want}");
            }
        }
    }
}

#[test]
fn the_native_reads_the_table_as_lowering_does() {
    let t = constant_table(0.2, 1.5, true).expect("kept");
    let node = |k: usize| f32::from_bits(t[k]);
    for cos in [-0.5f32, 0.0, 0.013, 0.5, 0.77, 63.0 / 63.0, 1.5] {
        let native = tsl_rough_transmittance(cos, 0.2, 1.5, 1.0);
        assert_eq!(native.to_bits(), lerp_transmittance(node, cos).to_bits(), "cos {cos}");
    }
    // At a node, the node's value; out of range, the end's.
    assert_eq!(lerp_transmittance(node, 32.0 / 63.0), node(32));
    assert_eq!(tsl_rough_transmittance(-1.0, 0.2, 1.5, 1.0), node(0));
    assert_eq!(tsl_rough_transmittance(2.0, 0.2, 1.5, 1.0), node(63));
    let point = GridPoint::new(0.2, 1.5, true).unwrap();
    assert_eq!(tsl_rough_internal_reflectance(0.2, 1.5, 1.0), point.internal_reflectance());
    // The same arguments give the same table, a grid node's roughness its
    // node unblended (0.125 = 2^-3).
    assert!(std::ptr::eq(t, constant_table(0.2, 1.5, true).unwrap()));
    let on_node = GridPoint::new(0.125, 2.0, false).unwrap();
    assert_eq!((on_node.alpha_weight, on_node.eta_weight), (0.0, 0.0));
    // Roughness below Mitsuba's floor is the floor.
    assert_eq!(tsl_rough_internal_reflectance(0.0, 1.5, 0.0), tsl_rough_internal_reflectance(1e-4, 1.5, 0.0));
    assert!(tsl_rough_transmittance(0.5, f32::NAN, 1.5, 0.0).is_nan());
    assert!(tsl_rough_internal_reflectance(0.1, f32::NAN, 1.0).is_nan());
    assert_eq!(table_name(t), Some("rough_transmittance"));
}
