//! Players made of blobs: a *player folder* (what host-trainer exports for a trained team
//! member) and [`BlobPlayer`], which plays its three actor blobs through policy-core's runtime
//! [`Model`], the exact bytes a chip would run.
//!
//! The folder holds `player.toml` and the blobs it names, by paths relative to the folder:
//!
//! ```toml
//! format = 1                       # manifest version; anything else is refused
//! label = "dcp-t16__0__p03"        # shown in reports (at most 64 characters)
//! scenario = "scenario.toml"       # the badminton scenario it trained on (optional)
//! [actors]                         # one actor blob per agent
//! catch = "catch.postcard"
//! serve = "serve.postcard"
//! reset = "reset.postcard"
//! [critics]                        # optional; read, not run, by `match`
//! catch = "catch-critic.postcard"
//! serve = "serve-critic.postcard"
//! reset = "reset-critic.postcard"
//! ```
//!
//! Two kinds of failure, told apart as a chip and a user would tell them apart:
//! - **the folder is wrong** (an [`Error::Player`], one line, before anything plays): no
//!   `player.toml`, a manifest that does not parse, has an unknown key or a `format` other than
//!   1, a path that is absolute, has a `..` component or resolves (symbolic links followed)
//!   outside the folder, a named file missing or unreadable, a label too long, or an actor blob
//!   that verifies but is a critic or has the wrong shape for its agent (catch 10 → 2, serve
//!   10 → 3, reset 10 → 2): the user gave the wrong file;
//! - **an actor blob does not verify** (corrupt bytes, a CRC mismatch, a non-finite
//!   parameter): that agent plays the safe state (zero action), as a chip that cannot boot its
//!   blob does, and [`PlayerFolder::boot_errors`] says which agent and why, for the report.

use std::path::{Component, Path, PathBuf};

use policy_core::model::Model;
use serde::{Deserialize, Serialize};

use super::agent::Player;
use super::config::Config;
use super::game::{Role, OBSERVATIONS};
use crate::boot::{boot, boot_or_safe_state, PlantSizes};
use crate::controller::Controller;
use crate::error::parse_error;
use crate::files;
use crate::Error;

/// The manifest's file name inside a player folder.
pub const MANIFEST: &str = "player.toml";

/// The one manifest version this build reads.
pub const FORMAT: u32 = 1;

/// The longest label, in characters.
pub const MAX_LABEL: usize = 64;

/// `player.toml`: what a player folder holds. host-trainer writes it with this type (and
/// `toml`), this module reads it, so the two sides cannot drift apart.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The manifest version, [`FORMAT`] (read first, on its own: `Version`).
    pub format: u32,
    /// Shown in reports (at most [`MAX_LABEL`] characters).
    pub label: String,
    /// The badminton scenario file the player trained on, if named.
    pub scenario: Option<String>,
    /// One actor blob per agent.
    pub actors: PerRole,
    /// One critic blob per agent, if named (heat maps read them; matches do not run them).
    pub critics: Option<PerRole>,
}

/// Only the version, read before the rest so that a manifest of another version is refused
/// for its version, not for a key this build does not know.
#[derive(Deserialize)]
struct Version {
    format: u32,
}

/// One path per agent, relative to the player folder.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerRole {
    /// The catch agent's file.
    pub catch: String,
    /// The serve agent's file.
    pub serve: String,
    /// The reset agent's file.
    pub reset: String,
}

impl PerRole {
    /// The file of `role`'s agent.
    pub fn of(&self, role: Role) -> &str {
        match role {
            Role::Catch => &self.catch,
            Role::Serve => &self.serve,
            Role::Reset => &self.reset,
        }
    }
}

/// The sizes an agent's blob must have: 10 observations, and the role's actions.
pub fn sizes_of(role: Role) -> PlantSizes {
    PlantSizes {
        observations: OBSERVATIONS,
        actions: role.actions(),
    }
}

/// A player folder, loaded and checked: the blobs' bytes are held, so the folder may change
/// afterwards without changing what plays.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlayerFolder {
    /// The folder as given.
    pub folder: PathBuf,
    /// The manifest's label.
    pub label: String,
    /// The scenario file the player trained on (resolved, checked to load), if named.
    pub scenario: Option<PathBuf>,
    /// Each actor blob's file (resolved) and bytes, in [`Role::ALL`] order.
    pub actors: [(PathBuf, Vec<u8>); 3],
    /// The critic blobs' files and bytes, if named (not run by matches).
    pub critics: Option<[(PathBuf, Vec<u8>); 3]>,
    /// Why each actor blob does not boot (its agent plays the safe state), in role order.
    boot_errors: [Option<String>; 3],
}

impl PlayerFolder {
    /// Loads and checks a player folder (see the module's documentation for what is refused).
    pub fn load(folder: &Path) -> Result<PlayerFolder, Error> {
        let refuse = |message: String| Error::Player {
            player: folder.display().to_string(),
            message,
        };
        let root = folder
            .canonicalize()
            .map_err(|e| refuse(format!("cannot open the folder: {e}")))?;
        if !root.is_dir() {
            return Err(refuse(format!(
                "not a folder (a player folder holds {MANIFEST} and the blobs it names)"
            )));
        }
        if !root.join(MANIFEST).exists() {
            return Err(refuse(format!(
                "no {MANIFEST} in the folder (a player folder holds {MANIFEST} naming its blobs)"
            )));
        }
        let manifest_path = inside(&root, MANIFEST, MANIFEST).map_err(&refuse)?;
        let text = files::read_config_text(&manifest_path)
            .map_err(|e| refuse(format!("cannot read {MANIFEST}: {e}")))?;
        let origin = folder.join(MANIFEST).display().to_string();
        let version: Version =
            toml::from_str(&text).map_err(|e| parse_error(&e, &text, &origin))?;
        if version.format != FORMAT {
            return Err(refuse(format!(
                "{MANIFEST}: format {} is not one this build reads (format {FORMAT})",
                version.format
            )));
        }
        let manifest: Manifest =
            toml::from_str(&text).map_err(|e| parse_error(&e, &text, &origin))?;
        let label = manifest.label;
        if label.chars().count() > MAX_LABEL || label.chars().any(char::is_control) {
            return Err(refuse(format!(
                "{MANIFEST}: label {label:?}: must be at most {MAX_LABEL} characters, none of them control characters"
            )));
        }
        let scenario = match &manifest.scenario {
            Some(rel) => {
                let path = inside(&root, "scenario", rel).map_err(&refuse)?;
                let text = files::read_config_text(&path)
                    .map_err(|e| refuse(format!("scenario = {rel:?}: cannot read: {e}")))?;
                Config::from_toml_str(&text, &folder.join(rel).display().to_string())?;
                Some(path)
            }
            None => None,
        };
        let read = |table: &str, paths: &PerRole| -> Result<[(PathBuf, Vec<u8>); 3], Error> {
            let mut out = Role::ALL.map(|_| (PathBuf::new(), Vec::new()));
            for (slot, role) in out.iter_mut().zip(Role::ALL) {
                let rel = paths.of(role);
                let key = format!("{table}.{}", role.name());
                let path = inside(&root, &key, rel).map_err(&refuse)?;
                let bytes = files::read_blob(&path)
                    .map_err(|e| refuse(format!("{key} = {rel:?}: cannot read: {e}")))?;
                *slot = (path, bytes);
            }
            Ok(out)
        };
        let actors = read("actors", &manifest.actors)?;
        let critics = manifest
            .critics
            .as_ref()
            .map(|c| read("critics", c))
            .transpose()?;
        let mut boot_errors = [None, None, None];
        for ((role, (_, bytes)), error) in Role::ALL.iter().zip(&actors).zip(&mut boot_errors) {
            // Bytes that do not verify: the agent boots the safe state, as on a chip.
            if let Err(e) = Model::from_blob(bytes) {
                *error = Some(Error::from(e).to_string());
                continue;
            }
            // Bytes that verify but cannot be this agent: the wrong file was given.
            if let Err(e) = boot(bytes, &sizes_of(*role)) {
                let rel = manifest.actors.of(*role);
                let sizes = sizes_of(*role);
                return Err(refuse(format!(
                    "actors.{0} = {rel:?}: not a {0} agent ({e}; the {0} agent takes {1} observations and gives {2} actions)",
                    role.name(),
                    sizes.observations,
                    sizes.actions
                )));
            }
        }
        Ok(PlayerFolder {
            folder: folder.to_path_buf(),
            label,
            scenario,
            actors,
            critics,
            boot_errors,
        })
    }

    /// The agents whose blob does not boot (they play the safe state), and why.
    pub fn boot_errors(&self) -> impl Iterator<Item = (Role, &str)> + '_ {
        Role::ALL
            .into_iter()
            .zip(&self.boot_errors)
            .filter_map(|(role, e)| e.as_deref().map(|e| (role, e)))
    }
}

/// `rel`, the value of manifest key `key`, as a file inside `root` (canonical): refused when
/// absolute, with a `..` component, missing, or resolving (symbolic links followed) outside.
fn inside(root: &Path, key: &str, rel: &str) -> Result<PathBuf, String> {
    let path = Path::new(rel);
    if rel.is_empty() || path.has_root() || path.is_absolute() {
        return Err(format!(
            "{key} = {rel:?}: must be a path relative to the folder"
        ));
    }
    if path
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(format!(
            "{key} = {rel:?}: a `..` component leaves the folder (paths stay inside it)"
        ));
    }
    let real = root
        .join(path)
        .canonicalize()
        .map_err(|e| format!("{key} = {rel:?}: cannot read: {e}"))?;
    if !real.starts_with(root) {
        return Err(format!(
            "{key} = {rel:?}: resolves outside the folder, to {}",
            real.display()
        ));
    }
    if !real.is_file() {
        return Err(format!("{key} = {rel:?}: not a file"));
    }
    Ok(real)
}

/// A player whose agents are the blobs of a [`PlayerFolder`], each booted as a chip boots it:
/// verified once, then every decision runs policy-core's runtime model on the bytes (any
/// weight encoding: f32, f16, int8). An agent whose blob does not boot plays the safe state.
pub struct BlobPlayer<'a> {
    label: String,
    /// The booted agents (or safe states) in [`Role::ALL`] order.
    agents: [Box<dyn Controller + 'a>; 3],
}

impl core::fmt::Debug for BlobPlayer<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let agents: Vec<String> = self.agents.iter().map(|a| a.name()).collect();
        f.debug_struct("BlobPlayer")
            .field("label", &self.label)
            .field("agents", &agents)
            .finish()
    }
}

impl<'a> BlobPlayer<'a> {
    /// Boots the folder's three actors.
    pub fn boot(folder: &'a PlayerFolder) -> BlobPlayer<'a> {
        let agents = [0, 1, 2].map(|i| {
            let (_, bytes) = &folder.actors[i];
            boot_or_safe_state(bytes, &sizes_of(Role::ALL[i])).0
        });
        BlobPlayer {
            label: folder.label.clone(),
            agents,
        }
    }
}

impl Player for BlobPlayer<'_> {
    fn name(&self) -> String {
        self.label.clone()
    }

    fn act(&mut self, role: Role, observation: &[f32], action: &mut [f32]) {
        self.agents[role as usize].act(observation, action);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use policy_core::model::Scratch;
    use policy_core::{blob, ActionBounds, Activation, Encoding, Normalizer, Policy};

    /// A deterministic actor of the role's shape with weights that are not all zero.
    fn actor<const A: usize>(seed: u32) -> Vec<u8> {
        let mut p = Box::new(Policy::<OBSERVATIONS, 16, 1, A>::ZERO);
        p.normalizer = Normalizer::identity(20.0);
        p.bounds = ActionBounds::symmetric(1.0);
        p.trunk.activation = Activation::Tanh;
        let mut x = seed.wrapping_mul(2_654_435_761).max(1);
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        p.input
            .w
            .as_mut_slice()
            .iter_mut()
            .for_each(|w| *w = next());
        p.input
            .b
            .as_mut_slice()
            .iter_mut()
            .for_each(|w| *w = next());
        for layer in p.trunk.hidden.iter_mut() {
            layer
                .w
                .as_mut_slice()
                .iter_mut()
                .for_each(|w| *w = next() * 0.5);
        }
        p.trunk
            .output
            .w
            .as_mut_slice()
            .iter_mut()
            .for_each(|w| *w = next());
        p.to_blob("unit").expect("blob")
    }

    /// A `BlobPlayer` gives the bits policy-core's `Model::act` gives on the same blobs, for each
    /// weight encoding.
    #[test]
    fn a_blob_player_acts_bit_identically_to_the_runtime_model() {
        let f32_blobs = [actor::<2>(1), actor::<3>(2), actor::<2>(3)];
        for encoding in [Encoding::F32, Encoding::F16, Encoding::Int8] {
            let blobs = f32_blobs
                .clone()
                .map(|b| blob::encode(&b, encoding).expect("encode"));
            let folder = PlayerFolder {
                folder: PathBuf::from("mem"),
                label: "unit".into(),
                scenario: None,
                actors: blobs.clone().map(|b| (PathBuf::new(), b)),
                critics: None,
                boot_errors: [None, None, None],
            };
            let mut player = BlobPlayer::boot(&folder);
            let mut scratch = Scratch::<64>::new();
            for k in 0..50 {
                let obs: Vec<f32> = (0..OBSERVATIONS)
                    .map(|i| ((k * 7 + i * 3) % 23) as f32 * 0.9 - 9.0)
                    .collect();
                for (role, bytes) in Role::ALL.into_iter().zip(&blobs) {
                    let model = Model::from_blob(bytes).expect("model");
                    let mut want = vec![0.0f32; role.actions()];
                    model.act(&obs, &mut scratch, &mut want).expect("act");
                    let mut got = vec![f32::NAN; role.actions()];
                    player.act(role, &obs, &mut got);
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&got), bits(&want), "{encoding:?} {role:?} {obs:?}");
                    assert!(want.iter().any(|&a| a != 0.0), "a non-trivial action");
                }
            }
        }
    }
}
