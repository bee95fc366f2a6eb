//! One module per subcommand.

pub mod demo;
pub mod eval;
pub mod eval_identity;
pub mod experiment;
pub mod fit;
pub mod import;
pub mod mocap;
pub mod run;
pub mod simulate;
pub mod validate;
