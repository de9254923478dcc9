//! Messages waiting for the CAN transmitter: one slot per frame kind,
//! newest wins. The estimator posts without ever waiting; the transmitter
//! takes the most urgent first (lowest identifier). A message replaced
//! before it was sent is counted; as the E2E counter is assigned when a
//! frame is encoded for the bus, receivers do not see replaced messages
//! as gaps, only frames lost on the way.

use super::{Message, MessageKind};

/// The outbox.
#[derive(Clone, Debug, Default)]
pub struct Outbox {
    slots: [Option<Message>; MessageKind::COUNT],
    replaced: u32,
}

impl Outbox {
    /// An empty outbox.
    pub const fn new() -> Self {
        Self {
            slots: [None; MessageKind::COUNT],
            replaced: 0,
        }
    }

    /// Queue `msg`, replacing a pending message of the same kind.
    pub fn post(&mut self, msg: Message) {
        let slot = &mut self.slots[msg.kind() as usize];
        if slot.is_some() {
            self.replaced = self.replaced.wrapping_add(1);
        }
        *slot = Some(msg);
    }

    /// The most urgent pending message.
    pub fn take_next(&mut self) -> Option<Message> {
        self.slots.iter_mut().find_map(Option::take)
    }

    /// Is anything pending?
    pub fn is_empty(&self) -> bool {
        self.slots.iter().all(Option::is_none)
    }

    /// Messages replaced before they were sent, since start (wrapping).
    pub fn replaced(&self) -> u32 {
        self.replaced
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{Command, CommandFrame, HeartbeatFrame, ResetCause};

    fn heartbeat(uptime_s: u16) -> Message {
        Message::Heartbeat(HeartbeatFrame {
            reset_cause: ResetCause::PowerOn,
            uptime_s,
            estimator_load_pct: 0,
            peak_load_pct: 0,
            missed_samples: 0,
            adc_overruns: 0,
            can_tx_dropped: 0,
        })
    }

    #[test]
    fn newest_wins_and_most_urgent_goes_first() {
        let mut o = Outbox::new();
        assert!(o.is_empty() && o.take_next().is_none());
        o.post(heartbeat(1));
        o.post(heartbeat(2));
        let cmd = Message::Command(CommandFrame {
            command: Command::AcknowledgeAlarm,
            mac: [0; 6],
        });
        o.post(cmd);
        assert_eq!(o.replaced(), 1);
        assert_eq!(o.take_next(), Some(heartbeat(2)));
        assert_eq!(o.take_next(), Some(cmd));
        assert!(o.is_empty());
    }
}
