//! Ctrl-C and SIGTERM as a flag the serve loop reads, so that it stops cleanly (the engine
//! flushed, the last decisions published).

use crate::{LiveError, Result};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Sets `stop` when the process receives SIGINT (Ctrl-C) or SIGTERM. A second signal after the
/// first ends the process at once (exit status 130).
pub fn stop_on_signals(stop: Arc<AtomicBool>) -> Result<()> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .build()
        .map_err(|e| LiveError::Io {
            what: "cannot start the signal handler".to_owned(),
            source: e,
        })?;
    let (ready_tx, ready) = std::sync::mpsc::sync_channel(1);
    std::thread::Builder::new()
        .name("nomen-signals".to_owned())
        .spawn(move || {
            runtime.block_on(async move {
                use tokio::signal::unix::{SignalKind, signal};
                let (Ok(mut int), Ok(mut term)) = (
                    signal(SignalKind::interrupt()),
                    signal(SignalKind::terminate()),
                ) else {
                    let _ = ready_tx.send(false);
                    return;
                };
                let _ = ready_tx.send(true);
                for _ in 0..2 {
                    tokio::select! {
                        _ = int.recv() => {}
                        _ = term.recv() => {}
                    }
                    if stop.swap(true, Ordering::Relaxed) {
                        std::process::exit(130);
                    }
                }
            });
        })
        .map_err(|e| LiveError::Io {
            what: "cannot start the signal handler".to_owned(),
            source: e,
        })?;
    match ready.recv() {
        Ok(true) => Ok(()),
        _ => Err(LiveError::Io {
            what: "cannot install the signal handlers".to_owned(),
            source: std::io::Error::other("signal registration failed"),
        }),
    }
}
