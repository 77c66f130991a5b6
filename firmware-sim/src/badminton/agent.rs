//! What sits in a seat of a badminton match: a [`Player`], its three agents behind one call
//! (the reference players, a player folder's blobs, or a trainer's own networks).

use super::game::Role;

/// A badminton player: its three agents behind one call.
pub trait Player {
    /// Name used in reports.
    fn name(&self) -> String;
    /// The action of the player's `role` agent for this observation (own frame), written into
    /// `action` (2 numbers for catch and reset, 3 for serve).
    fn act(&mut self, role: Role, observation: &[f32], action: &mut [f32]);
}
