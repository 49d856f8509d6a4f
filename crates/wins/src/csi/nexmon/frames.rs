//! The packets of one received frame grouped: nexmon_csi sends one packet per receive core and
//! spatial stream. Retransmissions keep the sequence number, so a run of equal sequence numbers
//! can hold several frames: a frame ends when a (core, stream) it already has comes again, or the
//! sequence number or the transmitter changes. Packets can be lost, so a frame may lack cores;
//! [`NexmonFrame::cores`] says which it has.

use super::NexmonPacket;

/// The packets of one received frame.
#[derive(Clone, Debug, PartialEq)]
pub struct NexmonFrame<'a> {
    /// Its packets, in file order, one per (core, stream).
    pub packets: Vec<&'a NexmonPacket>,
}

impl NexmonFrame<'_> {
    /// The cores it has, in increasing order.
    pub fn cores(&self) -> Vec<u8> {
        let mut cores: Vec<u8> = self.packets.iter().map(|p| p.core()).collect();
        cores.sort_unstable();
        cores.dedup();
        cores
    }
}

/// The frames of `packets` (module doc), in file order.
pub fn frames(packets: &[NexmonPacket]) -> Vec<NexmonFrame<'_>> {
    let mut out: Vec<NexmonFrame<'_>> = Vec::new();
    for p in packets {
        let joins = out
            .last()
            .is_some_and(|f| joins(f.packets.iter().copied(), p));
        match out.last_mut() {
            Some(f) if joins => f.packets.push(p),
            _ => out.push(NexmonFrame { packets: vec![p] }),
        }
    }
    out
}

/// Whether `p` belongs to the frame of `frame`'s packets (module doc): the same sequence number
/// and transmitter as its first, and a (core, stream) it does not have yet. Not to an empty one.
fn joins<'a>(mut frame: impl Iterator<Item = &'a NexmonPacket>, p: &NexmonPacket) -> bool {
    let Some(first) = frame.next() else {
        return false;
    };
    let key = |q: &NexmonPacket| (q.core(), q.spatial_stream());
    first.seq == p.seq
        && first.transmitter == p.transmitter
        && key(first) != key(p)
        && frame.all(|q| key(q) != key(p))
}

/// Frames assembled from packets as they arrive (a live stream): a frame is handed out as soon
/// as it has `cores` packets, or when a packet that cannot join it comes (module doc); the last
/// one by [`FrameAssembler::flush`].
#[derive(Clone, Debug, Default)]
pub struct FrameAssembler {
    cores: usize,
    open: Vec<NexmonPacket>,
}

impl FrameAssembler {
    /// An assembler of frames of `cores` packets (one stream per core).
    pub fn new(cores: usize) -> Self {
        Self {
            cores,
            open: Vec::new(),
        }
    }

    /// Takes `p`; returns the frames it closed (the open one, if `p` cannot join it, and the
    /// one `p` completed).
    pub fn push(&mut self, p: NexmonPacket) -> Vec<Vec<NexmonPacket>> {
        let mut out = Vec::new();
        if !joins(self.open.iter(), &p) && !self.open.is_empty() {
            out.push(std::mem::take(&mut self.open));
        }
        self.open.push(p);
        if self.open.len() >= self.cores {
            out.push(std::mem::take(&mut self.open));
        }
        out
    }

    /// The open frame, if any.
    pub fn flush(&mut self) -> Option<Vec<NexmonPacket>> {
        (!self.open.is_empty()).then(|| std::mem::take(&mut self.open))
    }
}
