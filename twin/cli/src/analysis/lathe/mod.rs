//! Phase-plane analysis of the parallel lathe's power loop (Sudhakara & Landers, ACC 2003) on
//! its reduced model, Sudhakara eqs (16)–(23) in `models::lathe::closed_loop`: equilibria and their
//! stability (Figs 6–7), the phase portrait from a grid of positive initial forces (Figs 4–5),
//! the region-of-attraction boundary by reverse trajectories from each saddle (Fig 8) and the
//! saturation lines of Sudhakara eq (21) (Fig 9).

mod output;
mod phase_plane;

pub use phase_plane::{analyze, Gains, PhasePlane, PhasePlaneRequest, RegionExtent};
