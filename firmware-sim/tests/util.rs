use policy_core::blob::{self, Spec};
use policy_core::{ActionBounds, Activation, ModelKind, Normalizer, Policy, Shape};
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

/// A blob of any runtime shape through policy-core's writer: identity normaliser (clip 5),
/// bounds ±0.25 (actor, discrete), for a discrete policy a table whose row `k` is
/// `(-0.25 + 0.5 k / (choices - 1), ...)`, and DDPG-style random weights.
pub fn runtime_blob(
    kind: ModelKind,
    shape: Shape,
    activation: Activation,
    seed: u64,
    label: &str,
) -> Vec<u8> {
    let (s, a, k) = (
        shape.observations as usize,
        shape.actions as usize,
        shape.choices as usize,
    );
    let mut params = vec![0.0; s];
    params.extend(std::iter::repeat_n(1.0, s));
    params.push(5.0);
    if kind != ModelKind::Critic {
        params.extend(std::iter::repeat_n(-0.25, a));
        params.extend(std::iter::repeat_n(0.25, a));
    }
    for row in 0..k {
        let v = -0.25 + 0.5 * row as f32 / (k.max(2) - 1) as f32;
        params.extend(std::iter::repeat_n(v, a));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut inputs = shape.inputs(kind);
    let width = shape.width as usize;
    for layer in 0..=shape.depth as usize {
        let outputs = if layer == shape.depth as usize {
            shape.outputs(kind)
        } else {
            width
        };
        let start = params.len();
        params.resize(start + inputs * outputs + outputs, 0.0);
        fill(&mut params[start..], inputs, &mut rng);
        inputs = width;
    }
    let spec = Spec {
        kind,
        encoding: policy_core::Encoding::F32,
        shape,
        activation,
        label,
    };
    blob::to_vec_with(&spec, &mut |sink| sink(&params)).expect("blob")
}

/// A badminton actor blob (10 observations, `actions` actions, 2×16 tanh) with random weights,
/// its weights stored in `encoding`.
pub fn badminton_actor(
    actions: u16,
    seed: u64,
    encoding: policy_core::Encoding,
    label: &str,
) -> Vec<u8> {
    let f32_blob = badminton_blob(ModelKind::Actor, actions, seed, label);
    blob::encode(&f32_blob, encoding).expect("encode")
}

/// A badminton agent's f32 blob of `kind` (actor or critic): 10 observations, `actions`
/// actions, 2×16 tanh, random weights from `seed`.
pub fn badminton_blob(kind: ModelKind, actions: u16, seed: u64, label: &str) -> Vec<u8> {
    let shape = Shape {
        observations: 10,
        actions,
        width: 16,
        depth: 2,
        choices: 0,
    };
    runtime_blob(kind, shape, Activation::Tanh, seed, label)
}

/// The manifest of a player folder with the three actors (and critics, if `critics`) under
/// their usual names.
pub const PLAYER_TOML: &str = "format = 1
label = \"example\"
[actors]
catch = \"catch.postcard\"
serve = \"serve.postcard\"
reset = \"reset.postcard\"
";

/// Writes a player folder into `dir` (created): `PLAYER_TOML` and an f32 catch actor, an f16
/// serve actor and an int8 reset actor (the folder under tests/data/example-player).
pub fn write_example_player(dir: &std::path::Path) {
    use policy_core::Encoding;
    std::fs::create_dir_all(dir).expect("player folder");
    std::fs::write(dir.join("player.toml"), PLAYER_TOML).expect("manifest");
    for (name, actions, seed, encoding) in [
        ("catch", 2, 1, Encoding::F32),
        ("serve", 3, 2, Encoding::F16),
        ("reset", 2, 3, Encoding::Int8),
    ] {
        let blob = badminton_actor(actions, seed, encoding, &format!("example {name}"));
        std::fs::write(dir.join(format!("{name}.postcard")), blob).expect("blob");
    }
}

/// A fresh directory under the system's temporary folder, removed when the test ends.
pub struct Scratch(pub std::path::PathBuf);

impl Scratch {
    /// `{prefix}-{pid}-{name}`, emptied first.
    pub fn new(prefix: &str, name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("{prefix}-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch dir");
        Scratch(dir)
    }

    /// A path inside.
    pub fn path(&self, name: &str) -> std::path::PathBuf {
        self.0.join(name)
    }

    /// A path inside, as a string for the command line.
    pub fn file(&self, name: &str) -> String {
        self.path(name).display().to_string()
    }

    /// The names of what it holds, sorted.
    pub fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .expect("read dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    /// A player folder `name` like the example, with its manifest replaced by `manifest`.
    pub fn player(&self, name: &str, manifest: &str) -> String {
        let dir = self.path(name);
        write_example_player(&dir);
        std::fs::write(dir.join("player.toml"), manifest).expect("manifest");
        dir.display().to_string()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Runs `firmware-sim SUBCOMMAND ARGS...` to its end.
pub fn firmware_sim(subcommand: &str, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_firmware-sim"))
        .arg(subcommand)
        .args(args)
        .output()
        .expect("spawn firmware-sim")
}

/// A process's standard error as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A process's standard output as text.
pub fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}
