//! Signal filters for wearables and skeletons: orientation (complementary, Madgwick, Mahony), Kalman and Tobit Kalman, zero-phase low-pass, derivatives, gravity removal and window synchronisation.

mod error;
pub use error::{FilterError, Result};
pub mod orientation;

pub mod derivative;
pub mod gravity;
pub mod kalman;
pub mod lowpass;
pub mod robust;
pub use robust::median;
pub mod sync;
#[cfg(test)]
mod test_bits;
pub mod tobit;
