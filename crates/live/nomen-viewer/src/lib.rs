//! The live web viewer of nomen serve: the room in 3D with named and anonymous skeletons, tag fixes, sensor health and events, served over HTTP with server-sent events.
//!
//! [`state`] is sans-IO: it turns the values `nomen serve`'s session loop hands over (registry,
//! decisions, events, health) into what the page draws, and is tested without a socket.
//! [`server`] serves the page, its embedded files ([`assets`]: three.js is vendored, nothing is
//! fetched at run time) and the live frames, behind the [`access`] rules: a loopback address
//! needs no token, any other does. The page receives skeletons and counts only, never images.
//! `docs/live.md` describes the page and its `data-` attributes.

pub mod access;
pub mod assets;
mod error;
pub mod server;
pub mod state;

pub use error::{Result, ViewerError};
pub use server::{Viewer, ViewerOptions};
pub use state::{ViewerConfig, ViewerState};
