//! A dataset's inputs merged by time ([`Events`]): the order a run consumes them in, as a live
//! driver would push them. One merge serves a dataset read from its files as it is consumed
//! ([`super::stream::DatasetStream::events`]) and one held in memory ([`super::Dataset::events`]),
//! so the two give a run the same inputs in the same order.
//!
//! The order: by time; at the same time a CSI record before a barometer reading before an IMU
//! sample; records of several APs at the same time in manifest order; each AP's records by time,
//! then in the order they were kept.

use std::fmt;

use super::baro_csv::BaroSample;
use super::checks::CsiPacket;
use super::load::DatasetError;
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// One input, in time order.
#[derive(Clone, Debug, PartialEq)]
pub enum DatasetEvent {
    /// A CSI record of AP `ap` (manifest order).
    Csi {
        /// The AP's index.
        ap: usize,
        /// The record on the IMU clock (boxed: it is the large one).
        packet: Box<CsiPacket>,
    },
    /// A barometer reading.
    Baro(BaroSample),
    /// An IMU sample.
    Imu(ImuSample),
}

/// Where [`Events`] takes the next kept IMU sample and each AP's next kept record from, each in
/// its own time order.
pub(crate) trait Sources: fmt::Debug {
    /// The next kept IMU sample, `None` after the last.
    fn next_imu(&mut self) -> Result<Option<ImuSample>, DatasetError>;
    /// AP `ap`'s next kept record in time order, `None` after the last.
    fn next_packet(&mut self, ap: usize) -> Result<Option<CsiPacket>, DatasetError>;
    /// The number of APs.
    fn aps(&self) -> usize;
    /// Per AP, the stretches its log reader skipped and their bytes, so far.
    fn skips(&self) -> Vec<(u64, u64)>;
    /// Records waiting in the sources to be put in time order.
    fn buffered(&self) -> usize;
}

/// The inputs merged by time (module docs).
#[derive(Debug)]
pub struct Events<'a> {
    sources: Box<dyn Sources + 'a>,
    imu_head: Option<ImuSample>,
    baro: Vec<BaroSample>,
    baro_next: usize,
    heads: Vec<Option<CsiPacket>>,
    started: bool,
}

impl<'a> Events<'a> {
    /// The merge of `sources` and the barometer readings `baro` (in time order).
    pub(crate) fn new(sources: Box<dyn Sources + 'a>, baro: Vec<BaroSample>) -> Self {
        let heads = vec![None; sources.aps()];
        Self {
            sources,
            imu_head: None,
            baro,
            baro_next: 0,
            heads,
            started: false,
        }
    }

    /// Records held now, every AP's together (those waiting to be put in time order and the
    /// next of each AP): for a dataset read from its files, bounded by the records within 0.1 s
    /// of NIC time, not by the log's length.
    pub fn held(&self) -> usize {
        self.sources.buffered() + self.heads.iter().filter(|h| h.is_some()).count()
    }

    /// Per AP, the stretches its log reader skipped and their bytes, so far.
    pub fn skips(&self) -> Vec<(u64, u64)> {
        self.sources.skips()
    }

    /// The next input, or `None` after the last.
    pub fn next_event(&mut self) -> Result<Option<DatasetEvent>, DatasetError> {
        if !self.started {
            self.started = true;
            self.imu_head = self.sources.next_imu()?;
            for (l, head) in self.heads.iter_mut().enumerate() {
                *head = self.sources.next_packet(l)?;
            }
        }
        // (time, 0 = packet / 1 = barometer / 2 = IMU, AP)
        let mut best: Option<(Timestamp, u8, usize)> = None;
        let mut consider = |key: (Timestamp, u8, usize)| {
            if best.is_none_or(|b| key < b) {
                best = Some(key);
            }
        };
        for (l, head) in self.heads.iter().enumerate() {
            if let Some(p) = head {
                consider((p.t, 0, l));
            }
        }
        if let Some(b) = self.baro.get(self.baro_next) {
            consider((b.t, 1, 0));
        }
        if let Some(s) = &self.imu_head {
            consider((s.t, 2, 0));
        }
        let Some((_, kind, l)) = best else {
            return Ok(None);
        };
        Ok(Some(match kind {
            0 => {
                let next = self.sources.next_packet(l)?;
                match std::mem::replace(&mut self.heads[l], next) {
                    Some(packet) => DatasetEvent::Csi {
                        ap: l,
                        packet: Box::new(packet),
                    },
                    None => return Ok(None),
                }
            }
            1 => {
                self.baro_next += 1;
                DatasetEvent::Baro(self.baro[self.baro_next - 1])
            }
            _ => {
                let next = self.sources.next_imu()?;
                match std::mem::replace(&mut self.imu_head, next) {
                    Some(s) => DatasetEvent::Imu(s),
                    None => return Ok(None),
                }
            }
        }))
    }
}

impl super::Dataset {
    /// The kept IMU samples, barometer readings (when `with_baro`) and CSI records, merged by
    /// time as [`super::stream::DatasetStream::events`] merges them from the files.
    pub fn events(&self, with_baro: bool) -> Events<'_> {
        let baro = if with_baro {
            self.baro.clone()
        } else {
            Vec::new()
        };
        Events::new(Box::new(InMemory::new(self)), baro)
    }
}

/// A dataset in memory as [`Sources`]: each AP's records by time, then in their order in the
/// log (the order a log read as it is consumed releases them from its reorder buffer).
#[derive(Debug)]
pub(crate) struct InMemory<'a> {
    dataset: &'a super::Dataset,
    next_imu: usize,
    /// Per AP, its records' indices in time order, and the next to give.
    order: Vec<(Vec<usize>, usize)>,
}

impl<'a> InMemory<'a> {
    /// The sources of `dataset`.
    pub(crate) fn new(dataset: &'a super::Dataset) -> Self {
        let order = dataset
            .aps
            .iter()
            .map(|ap| {
                let mut order: Vec<usize> = (0..ap.packets.len()).collect();
                // Stable: records at the same time stay in log order.
                order.sort_by_key(|&i| ap.packets[i].t);
                (order, 0)
            })
            .collect();
        Self {
            dataset,
            next_imu: 0,
            order,
        }
    }
}

impl Sources for InMemory<'_> {
    fn next_imu(&mut self) -> Result<Option<ImuSample>, DatasetError> {
        let s = self.dataset.imu.get(self.next_imu).copied();
        self.next_imu += 1;
        Ok(s)
    }

    fn next_packet(&mut self, ap: usize) -> Result<Option<CsiPacket>, DatasetError> {
        let (Some((order, next)), Some(log)) = (self.order.get_mut(ap), self.dataset.aps.get(ap))
        else {
            return Ok(None);
        };
        let packet = order.get(*next).map(|&i| log.packets[i].clone());
        *next += 1;
        Ok(packet)
    }

    fn aps(&self) -> usize {
        self.dataset.aps.len()
    }

    fn skips(&self) -> Vec<(u64, u64)> {
        self.dataset
            .aps
            .iter()
            .map(|ap| (ap.skips.len() as u64, ap.skips.iter().map(|k| k.len).sum()))
            .collect()
    }

    fn buffered(&self) -> usize {
        0
    }
}
