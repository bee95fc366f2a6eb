//! A bank of RSSI filters: one [`RssiKalman`] per (tag, antenna), fed with reads in time order
//! and queried for every tag's filtered RSSI at a frame time. This is the state the engine keeps
//! to call [`crate::likelihood::log_likelihood`] per frame.

use crate::error::{Result, RssiError};
use crate::kalman::{RssiEstimate, RssiKalman, RssiKalmanConfig};
use crate::model::RssiModel;
use crate::read::{RssiUnit, checked_rssi_dbm};
use nomen_core::{RssiRead, SessionTime, TagId};
use std::collections::BTreeMap;

/// One (tag, antenna) filter per model antenna for every tag heard.
#[derive(Debug, Clone)]
pub struct FilterBank {
    model: RssiModel,
    config: RssiKalmanConfig,
    unit: RssiUnit,
    tags: BTreeMap<TagId, Vec<RssiKalman>>,
}

impl FilterBank {
    /// An empty bank for `model`'s antennas. `unit` is the unit the reader reports.
    pub fn new(model: &RssiModel, config: RssiKalmanConfig, unit: RssiUnit) -> Result<Self> {
        config.validate()?;
        model.validate()?;
        Ok(Self {
            model: model.clone(),
            config,
            unit,
            tags: BTreeMap::new(),
        })
    }

    /// The model the bank filters for.
    pub fn model(&self) -> &RssiModel {
        &self.model
    }

    /// Applies one read. Errors (the read is not applied): NaN or implausible RSSI (dBm×100
    /// without `RssiUnit::CentiDbm`), an antenna the model does not know. The measurement
    /// variance is the antenna's σ² at the distance the read implies (at the boresight).
    pub fn push(&mut self, read: &RssiRead) -> Result<()> {
        let rssi = checked_rssi_dbm(read, self.unit)?;
        let Some((k, antenna)) = self.model.antenna(&read.antenna) else {
            return Err(RssiError::UnknownAntenna {
                tag: read.tag.to_string(),
                antenna: read.antenna.to_string(),
                t_s: read.t.as_secs_f64(),
                what: "model",
            });
        };
        let d = antenna
            .distance_for(rssi, 0.0)
            .unwrap_or(1.0)
            .clamp(antenna.min_distance_m, 1e3);
        let r = antenna.noise.variance_db2(d, 0.0);
        let num_antennas = self.model.antennas.len();
        let config = self.config;
        let filters = match self.tags.get_mut(&read.tag) {
            Some(f) => f,
            None => {
                let mut v = Vec::with_capacity(num_antennas);
                for _ in 0..num_antennas {
                    v.push(RssiKalman::new(config)?);
                }
                self.tags.entry(read.tag.clone()).or_insert(v)
            }
        };
        if let Some(f) = filters.get_mut(k) {
            f.update(read.t, rssi, r)?;
        }
        Ok(())
    }

    /// Every tag's filtered RSSI per model antenna at `t` into `out` (cleared first); `None` for
    /// an antenna that has not heard the tag within the reset window. Returns true when at least
    /// one antenna has an estimate.
    pub fn estimates_at(
        &self,
        tag: &TagId,
        t: SessionTime,
        out: &mut Vec<Option<RssiEstimate>>,
    ) -> bool {
        out.clear();
        match self.tags.get(tag) {
            Some(filters) => out.extend(filters.iter().map(|f| f.estimate_at(t))),
            None => out.extend(self.model.antennas.iter().map(|_| None)),
        }
        out.iter().any(Option::is_some)
    }

    /// The latest read of `tag` on any antenna.
    pub fn last_read(&self, tag: &TagId) -> Option<SessionTime> {
        self.tags
            .get(tag)?
            .iter()
            .filter_map(RssiKalman::last_read)
            .max()
    }

    /// Tags with filters, in id order.
    pub fn tags(&self) -> impl Iterator<Item = &TagId> {
        self.tags.keys()
    }

    /// Drops tags that no antenna has heard for longer than the reset window before `t`; returns
    /// how many were dropped and calls `dropped` with each.
    pub fn forget_silent(&mut self, t: SessionTime, dropped: &mut dyn FnMut(&TagId)) -> usize {
        let limit = self.config.reset_after_s;
        let before = self.tags.len();
        self.tags.retain(|tag, filters| {
            let alive = filters
                .iter()
                .filter_map(RssiKalman::last_read)
                .any(|last| t.secs_since(last) <= limit);
            if !alive {
                dropped(tag);
            }
            alive
        });
        before - self.tags.len()
    }
}
