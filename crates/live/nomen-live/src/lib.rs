//! The live service: nomen's engine fed from and publishing to MQTT (embedded broker or an existing one), with sensor health, events and recording replay.
//!
//! The sans-IO parts take data and time as arguments and never touch a socket: the topic scheme
//! ([`topics`]), payload decoding ([`decode`]), sensor health ([`health`]), the events derived
//! from the decisions ([`events`]), the session that drives the engine ([`session`]) and replay
//! pacing ([`replay::Pacer`]). The network parts are thin: [`broker`] embeds rumqttd, [`tls`]
//! sets up TLS (rustls) for clients and for the embedded broker, [`serve()`] and
//! [`replay::replay`] speak MQTT through rumqttc's blocking client. `docs/live.md` describes
//! the topics, payloads and QoS.

pub mod broker;
pub mod config;
pub mod decode;
mod error;
pub mod events;
pub mod health;
pub mod log;
pub mod outbox;
pub mod record;
pub mod replay;
mod serve;
pub mod session;
pub mod signals;
pub mod tls;
pub mod topics;

pub use config::ServeConfig;
pub use error::{LiveError, Result};
pub use serve::{DecisionSink, Observer, ServeOptions, ServeSummary, serve};
