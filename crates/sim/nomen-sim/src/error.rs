use thiserror::Error;

/// Everything that can go wrong while building or running a scene.
#[derive(Debug, Error)]
pub enum SimError {
    /// The scenario is inconsistent or out of range; the message names the field.
    #[error("invalid scenario: {0}")]
    InvalidScenario(String),
    /// The scene's messages take more memory than a simulated scene may hold
    /// ([`crate::scene::MAX_SCENE_MESSAGE_BYTES`]): the simulator holds a whole scene.
    #[error(
        "the scene is too large to simulate: {what} take about {estimate_mib:.0} MiB in memory \
         ({detail}), more than the {max_mib} MiB a simulated scene may hold; shorten duration_s \
         ({max_duration_s:.0} s surely fits) or simulate fewer people, cameras or wearables"
    )]
    TooLarge {
        /// What passes the bound: one camera's skeletons, the wearables' messages, the
        /// messages held so far.
        what: String,
        /// Their size, estimated or counted, MiB.
        estimate_mib: f64,
        /// The bound, MiB.
        max_mib: u64,
        /// What the estimate is made of: people, seconds, cameras and rates, wearables.
        detail: String,
        /// A duration at which these people, cameras and wearables surely fit, seconds: every
        /// camera seeing every person.
        max_duration_s: f64,
    },
    /// A fault to inject has a level out of its range; the message names the field.
    #[error("invalid fault: {0}")]
    InvalidFault(String),
    /// A motion-capture clip could not be used.
    #[error("motion capture: {0}")]
    Mocap(#[from] nomen_mocap::MocapError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, SimError>;
