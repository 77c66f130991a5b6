use policy_core::{ActionBounds, Activation, Normalizer, Policy};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// A policy with DDPG-style random weights (uniform ±1/√fan_in), identity normaliser with
/// clip 5 and the navigation box, as a blob.
pub fn random_blob<const H: usize, const L: usize>(seed: u64, label: &str) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut p = Box::new(Policy::<2, H, L, 2>::ZERO);
    p.normalizer = Normalizer::identity(5.0);
    p.bounds = ActionBounds::symmetric(0.25);
    p.trunk.activation = Activation::Tanh;
    fill(p.input.w.as_mut_slice(), 2, &mut rng);
    fill(p.input.b.as_mut_slice(), 2, &mut rng);
    for layer in p.trunk.hidden.iter_mut() {
        fill(layer.w.as_mut_slice(), H, &mut rng);
        fill(layer.b.as_mut_slice(), H, &mut rng);
    }
    fill(p.trunk.output.w.as_mut_slice(), H, &mut rng);
    fill(p.trunk.output.b.as_mut_slice(), H, &mut rng);
    p.to_blob(label).expect("blob")
}

fn fill(values: &mut [f32], fan_in: usize, rng: &mut ChaCha8Rng) {
    let k = 1.0 / (fan_in as f32).sqrt();
    for v in values {
        let u = (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        *v = (2.0 * u - 1.0) * k;
    }
}
