//! The receiver side of AUTOSAR E2E profile 1 as the E2E library
//! specifies it (`E2E_P01Check`, `E2E_P01MapStatusToSM`, `E2E_SMCheck`),
//! for the one frame the monitor receives: the command frame.
//!
//! Three layers, each a pure function of its inputs and state:
//!
//! 1. [`P01Check`]: per check cycle, the profile-specific status of the
//!    newest data ([`P01Status`]): CRC (with the Data ID), counter range,
//!    and the counter's delta to the last valid one against
//!    `MaxDeltaCounter` (which grows by one per check cycle without valid
//!    data, so that a sender that kept counting while frames were lost is
//!    still in sequence), `SyncCounter` re-synchronisation after a wrong
//!    sequence, and `MaxNoNewOrRepeatedData`.
//! 2. [`CheckStatus::of`]: the profile-independent status
//!    (`E2E_PCheckStatusType`: OK, REPEATED, WRONGSEQUENCE, NONEWDATA,
//!    ERROR), with the R4.2 profile behaviour: the first data after
//!    initialisation (`INITIAL`) is a wrong sequence, `SYNC` is OK.
//! 3. [`StateMachine`]: `E2E_SMCheck`: a window of the last
//!    `window_size` statuses; NODATA until the first usable status, then
//!    INIT → VALID when the window holds enough OKs and few enough
//!    ERRORs, VALID → INVALID when it does not, INVALID → VALID when it
//!    does again (each state with its own thresholds).
//!
//! [`Receiver`] chains the three. The command path acts on a command only
//! when this frame's status allows it *and* the channel's state machine is
//! not INVALID (see `command.rs`); the message authentication code is
//! checked after this, over the device's current challenge (`auth.rs`),
//! and is what makes a command fresh: the E2E counter detects a repeated
//! or lost frame on a healthy bus, not an attacker, who can compute the
//! CRC and choose the counter.

use super::e2e::{self, COUNTER_MAX};

/// Largest `MaxDeltaCounter` (the counter has 15 values).
const DELTA_LIMIT: u8 = COUNTER_MAX;
/// Longest state-machine window.
pub const MAX_WINDOW: usize = 16;

/// `E2E_P01ConfigType`, the check's part (the layout is fixed: CRC in
/// byte 0, counter in the low nibble of byte 1, Data ID mode "both").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct P01Config {
    /// Data ID (here: the CAN identifier).
    pub data_id: u16,
    /// Length of the data, bytes (`DataLength` / 8); other lengths are
    /// errors.
    pub data_len: u8,
    /// Largest counter delta between two valid data that is still in
    /// sequence (1: no data may be lost), 1..=14.
    pub max_delta_counter_init: u8,
    /// More check cycles than this without new data (or with repeated
    /// data) before valid data make the check re-synchronise.
    pub max_no_new_or_repeated_data: u8,
    /// Data in sequence needed after a wrong sequence before OK again.
    pub sync_counter_init: u8,
}

/// `E2E_P01CheckStatusType`: the profile-specific status of one check.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum P01Status {
    /// Counter incremented by one.
    Ok,
    /// No new data since the previous check cycle.
    NoNewData,
    /// The CRC (or the counter range) is wrong: corrupted, misrouted or
    /// forged without the CRC.
    WrongCrc,
    /// In sequence, but still re-synchronising after a wrong sequence
    /// or a long silence.
    Sync,
    /// The first valid data since initialisation: nothing to compare.
    Initial,
    /// The same counter as the last valid data.
    Repeated,
    /// Counter advanced by 2..=MaxDeltaCounter: some data lost.
    OkSomeLost,
    /// Counter advanced by more than MaxDeltaCounter.
    WrongSequence,
}

/// `E2E_PCheckStatusType`: the profile-independent status.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CheckStatus {
    /// Usable data in sequence.
    Ok,
    /// The same data again.
    Repeated,
    /// Counter out of sequence (or the first data after start).
    WrongSequence,
    /// Nothing new this cycle.
    NoNewData,
    /// Corrupted data.
    Error,
}

impl CheckStatus {
    /// `E2E_P01MapStatusToSM` with the R4.2 profile behaviour
    /// (`INITIAL` → WRONGSEQUENCE, `SYNC` → OK).
    pub const fn of(s: P01Status) -> Self {
        match s {
            P01Status::Ok | P01Status::OkSomeLost | P01Status::Sync => Self::Ok,
            P01Status::WrongCrc => Self::Error,
            P01Status::Repeated => Self::Repeated,
            P01Status::NoNewData => Self::NoNewData,
            P01Status::WrongSequence | P01Status::Initial => Self::WrongSequence,
        }
    }
}

/// `E2E_P01CheckStateType`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct P01Check {
    cfg: P01Config,
    last_valid_counter: u8,
    max_delta_counter: u8,
    wait_for_first_data: bool,
    lost_data: u8,
    no_new_or_repeated: u8,
    sync_counter: u8,
}

impl P01Check {
    /// `E2E_P01CheckInit`: waiting for the first data.
    pub const fn new(cfg: P01Config) -> Self {
        Self {
            cfg,
            last_valid_counter: 0,
            max_delta_counter: 0,
            wait_for_first_data: true,
            lost_data: 0,
            no_new_or_repeated: 0,
            sync_counter: 0,
        }
    }

    /// Data lost before the last valid data (its counter delta less one).
    pub const fn lost_data(&self) -> u8 {
        self.lost_data
    }

    /// `E2E_P01Check` for one check cycle: `data` is the newest received
    /// payload (8 bytes, CRC in byte 0), or `None` when nothing new came.
    pub fn check(&mut self, data: Option<&[u8]>) -> P01Status {
        // MaxDeltaCounter grows by one per check cycle (capped), so that
        // data lost between check cycles are tolerated.
        self.max_delta_counter = (self.max_delta_counter + 1).min(DELTA_LIMIT);
        let Some(data) = data else {
            self.no_new_or_repeated = (self.no_new_or_repeated + 1).min(DELTA_LIMIT);
            return P01Status::NoNewData;
        };
        if data.len() != self.cfg.data_len as usize {
            return P01Status::WrongCrc;
        }
        let Ok(counter) = e2e::check(self.cfg.data_id, data) else {
            return P01Status::WrongCrc;
        };
        if self.wait_for_first_data {
            self.wait_for_first_data = false;
            self.max_delta_counter = self.cfg.max_delta_counter_init;
            self.last_valid_counter = counter;
            return P01Status::Initial;
        }
        let delta = (counter + COUNTER_MAX + 1 - self.last_valid_counter) % (COUNTER_MAX + 1);
        if delta == 0 {
            self.no_new_or_repeated = (self.no_new_or_repeated + 1).min(DELTA_LIMIT);
            return P01Status::Repeated;
        }
        if delta > self.max_delta_counter {
            self.no_new_or_repeated = 0;
            self.sync_counter = self.cfg.sync_counter_init;
            if self.sync_counter > 0 {
                self.max_delta_counter = self.cfg.max_delta_counter_init;
                self.last_valid_counter = counter;
            }
            return P01Status::WrongSequence;
        }
        self.max_delta_counter = self.cfg.max_delta_counter_init;
        self.last_valid_counter = counter;
        self.lost_data = delta - 1;
        if self.no_new_or_repeated > self.cfg.max_no_new_or_repeated_data {
            self.sync_counter = self.cfg.sync_counter_init;
            self.no_new_or_repeated = 0;
            return P01Status::Sync;
        }
        self.no_new_or_repeated = 0;
        if self.sync_counter > 0 {
            self.sync_counter -= 1;
            return P01Status::Sync;
        }
        if delta == 1 {
            P01Status::Ok
        } else {
            P01Status::OkSomeLost
        }
    }
}

/// `E2E_SMConfigType`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SmConfig {
    /// Statuses kept in the window, 1..=[`MAX_WINDOW`].
    pub window_size: u8,
    /// INIT → VALID: at least this many OK …
    pub min_ok_state_init: u8,
    /// … and at most this many ERROR in the window (more: INVALID).
    pub max_error_state_init: u8,
    /// VALID stays VALID with at least this many OK …
    pub min_ok_state_valid: u8,
    /// … and at most this many ERROR.
    pub max_error_state_valid: u8,
    /// INVALID → VALID: at least this many OK …
    pub min_ok_state_invalid: u8,
    /// … and at most this many ERROR.
    pub max_error_state_invalid: u8,
}

/// `E2E_SMStateType` (DEINIT is unrepresentable: a state machine exists
/// only initialised).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmState {
    /// No usable data received yet.
    NoData,
    /// Data received, not enough evidence yet.
    Init,
    /// The channel works.
    Valid,
    /// Too many errors in the window.
    Invalid,
}

/// `E2E_SMCheckStateType`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StateMachine {
    cfg: SmConfig,
    window: [Option<CheckStatus>; MAX_WINDOW],
    top: u8,
    ok_count: u8,
    error_count: u8,
    state: SmState,
}

impl StateMachine {
    /// `E2E_SMCheckInit`: NODATA, empty window. The window size is
    /// clamped to 1..=[`MAX_WINDOW`].
    pub const fn new(mut cfg: SmConfig) -> Self {
        if cfg.window_size == 0 {
            cfg.window_size = 1;
        } else if cfg.window_size as usize > MAX_WINDOW {
            cfg.window_size = MAX_WINDOW as u8;
        }
        Self {
            cfg,
            window: [None; MAX_WINDOW],
            top: 0,
            ok_count: 0,
            error_count: 0,
            state: SmState::NoData,
        }
    }

    /// The state.
    pub const fn state(&self) -> SmState {
        self.state
    }

    /// OK and ERROR statuses in the window.
    pub const fn counts(&self) -> (u8, u8) {
        (self.ok_count, self.error_count)
    }

    fn add(&mut self, s: CheckStatus) {
        let n = self.cfg.window_size as usize;
        self.window[self.top as usize] = Some(s);
        let count = |want: CheckStatus| {
            self.window[..n]
                .iter()
                .filter(|&&w| w == Some(want))
                .count() as u8
        };
        self.ok_count = count(CheckStatus::Ok);
        self.error_count = count(CheckStatus::Error);
        self.top = if self.top as usize + 1 >= n {
            0
        } else {
            self.top + 1
        };
    }

    /// `E2E_SMCheck`: take one check cycle's status; returns the new state.
    pub fn check(&mut self, s: CheckStatus) -> SmState {
        let c = self.cfg;
        self.state = match self.state {
            SmState::NoData => {
                if matches!(s, CheckStatus::Error | CheckStatus::NoNewData) {
                    SmState::NoData
                } else {
                    SmState::Init
                }
            }
            SmState::Init => {
                self.add(s);
                if self.error_count <= c.max_error_state_init
                    && self.ok_count >= c.min_ok_state_init
                {
                    SmState::Valid
                } else if self.error_count > c.max_error_state_init {
                    SmState::Invalid
                } else {
                    SmState::Init
                }
            }
            SmState::Valid => {
                self.add(s);
                if self.error_count <= c.max_error_state_valid
                    && self.ok_count >= c.min_ok_state_valid
                {
                    SmState::Valid
                } else {
                    SmState::Invalid
                }
            }
            SmState::Invalid => {
                self.add(s);
                if self.error_count <= c.max_error_state_invalid
                    && self.ok_count >= c.min_ok_state_invalid
                {
                    SmState::Valid
                } else {
                    SmState::Invalid
                }
            }
        };
        self.state
    }
}

/// The outcome of one check cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Checked {
    /// Profile-specific status.
    pub p01: P01Status,
    /// Profile-independent status.
    pub status: CheckStatus,
    /// The channel's state after this status.
    pub state: SmState,
}

/// A P01 check and its state machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Receiver {
    check: P01Check,
    sm: StateMachine,
}

impl Receiver {
    /// A receiver that has seen nothing.
    pub const fn new(p01: P01Config, sm: SmConfig) -> Self {
        Self {
            check: P01Check::new(p01),
            sm: StateMachine::new(sm),
        }
    }

    /// One check cycle (`None`: no new data).
    pub fn check(&mut self, data: Option<&[u8]>) -> Checked {
        let p01 = self.check.check(data);
        let status = CheckStatus::of(p01);
        let state = self.sm.check(status);
        Checked { p01, status, state }
    }

    /// The channel's state.
    pub const fn state(&self) -> SmState {
        self.sm.state()
    }

    /// Data whose E2E protection was right but that the application
    /// refused (a field, or its authentication): an ERROR for the state
    /// machine, and the P01 check's counter state does not learn from it.
    pub fn reject(&mut self) -> SmState {
        self.sm.check(CheckStatus::Error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ID: u16 = 0x310;

    fn frame(counter: u8) -> [u8; 8] {
        let mut d = [0, 0x10, 1, 2, 3, 4, 5, 6];
        e2e::protect(ID, &mut d, counter);
        d
    }

    fn corrupt(counter: u8) -> [u8; 8] {
        let mut d = frame(counter);
        d[4] ^= 0x40;
        d
    }

    fn p01(max_delta: u8, sync: u8) -> P01Config {
        P01Config {
            data_id: ID,
            data_len: 8,
            max_delta_counter_init: max_delta,
            max_no_new_or_repeated_data: 3,
            sync_counter_init: sync,
        }
    }

    const SM: SmConfig = SmConfig {
        window_size: 4,
        min_ok_state_init: 2,
        max_error_state_init: 1,
        min_ok_state_valid: 1,
        max_error_state_valid: 1,
        min_ok_state_invalid: 3,
        max_error_state_invalid: 0,
    };

    #[test]
    fn p01_check_statuses() {
        let mut c = P01Check::new(p01(2, 0));
        assert_eq!(c.check(None), P01Status::NoNewData);
        assert_eq!(c.check(Some(&corrupt(0))), P01Status::WrongCrc);
        assert_eq!(c.check(Some(&frame(5))), P01Status::Initial);
        assert_eq!(c.check(Some(&frame(6))), P01Status::Ok);
        assert_eq!(c.check(Some(&frame(6))), P01Status::Repeated);
        assert_eq!(c.check(Some(&frame(8))), P01Status::OkSomeLost);
        assert_eq!(c.lost_data(), 1);
        // 8 → 12: delta 4 > MaxDeltaCounter (2, grown by one for this
        // check cycle: "after 1, accept 2 and 3 but not 4").
        assert_eq!(c.check(Some(&frame(12))), P01Status::WrongSequence);
        // Without re-synchronisation the last valid counter stays 8.
        assert_eq!(c.check(Some(&frame(9))), P01Status::Ok);
        // Wrap 14 → 0.
        let mut c = P01Check::new(p01(1, 0));
        c.check(Some(&frame(14)));
        assert_eq!(c.check(Some(&frame(0))), P01Status::Ok);
        // A counter of 15 is invalid like a bad CRC.
        let mut bad = [0u8, 0x1F, 0, 0, 0, 0, 0, 0];
        bad[0] = e2e::crc(ID, &bad);
        assert_eq!(c.check(Some(&bad)), P01Status::WrongCrc);
        assert_eq!(c.check(Some(&frame(1)[..7])), P01Status::WrongCrc);
        // The same frame under another Data ID fails its CRC.
        let mut other = P01Check::new(P01Config {
            data_id: 0x311,
            ..p01(1, 0)
        });
        assert_eq!(other.check(Some(&frame(1))), P01Status::WrongCrc);
    }

    #[test]
    fn max_delta_counter_grows_per_cycle_without_data() {
        let mut c = P01Check::new(p01(1, 0));
        c.check(Some(&frame(0)));
        // Each check cycle allows one more: after valid data a delta of
        // 1 + 1; after two cycles without data up to 1 + 3.
        c.check(None);
        c.check(None);
        assert_eq!(c.check(Some(&frame(4))), P01Status::OkSomeLost);
        // Right after valid data it is back at 1 + 1.
        assert_eq!(c.check(Some(&frame(6))), P01Status::OkSomeLost);
        assert_eq!(c.check(Some(&frame(9))), P01Status::WrongSequence);
    }

    #[test]
    fn wrong_sequence_resynchronises_with_sync_counter() {
        let mut c = P01Check::new(p01(1, 2));
        c.check(Some(&frame(0)));
        assert_eq!(c.check(Some(&frame(7))), P01Status::WrongSequence);
        // With a sync counter the new counter is adopted, but two frames
        // in sequence are needed before OK.
        assert_eq!(c.check(Some(&frame(8))), P01Status::Sync);
        assert_eq!(c.check(Some(&frame(9))), P01Status::Sync);
        assert_eq!(c.check(Some(&frame(10))), P01Status::Ok);
        // A long silence (more than 3 cycles without new data) also makes
        // the next valid data re-synchronise.
        for _ in 0..4 {
            c.check(None);
        }
        assert_eq!(c.check(Some(&frame(11))), P01Status::Sync);
    }

    #[test]
    fn status_mapping_follows_the_r4_2_profile_behaviour() {
        use CheckStatus as S;
        let map = [
            (P01Status::Ok, S::Ok),
            (P01Status::OkSomeLost, S::Ok),
            (P01Status::Sync, S::Ok),
            (P01Status::Initial, S::WrongSequence),
            (P01Status::WrongSequence, S::WrongSequence),
            (P01Status::Repeated, S::Repeated),
            (P01Status::NoNewData, S::NoNewData),
            (P01Status::WrongCrc, S::Error),
        ];
        for (p, s) in map {
            assert_eq!(CheckStatus::of(p), s, "{p:?}");
        }
    }

    #[test]
    fn state_machine_windows() {
        use CheckStatus as S;
        let mut sm = StateMachine::new(SM);
        assert_eq!(sm.state(), SmState::NoData);
        // Errors and silence keep NODATA.
        assert_eq!(sm.check(S::Error), SmState::NoData);
        assert_eq!(sm.check(S::NoNewData), SmState::NoData);
        // Anything else starts INIT (not counted in the window).
        assert_eq!(sm.check(S::WrongSequence), SmState::Init);
        assert_eq!(sm.check(S::Ok), SmState::Init);
        assert_eq!(sm.check(S::Ok), SmState::Valid);
        assert_eq!(sm.counts(), (2, 0));
        // One error in the window of 4 is tolerated in VALID …
        assert_eq!(sm.check(S::Error), SmState::Valid);
        // … two are not.
        assert_eq!(sm.check(S::Error), SmState::Invalid);
        assert_eq!(sm.counts(), (2, 2));
        // INVALID needs 3 OK and no error in the window: four OKs.
        assert_eq!(sm.check(S::Ok), SmState::Invalid);
        assert_eq!(sm.check(S::Ok), SmState::Invalid);
        assert_eq!(sm.check(S::Ok), SmState::Invalid);
        assert_eq!(sm.check(S::Ok), SmState::Valid);
        assert_eq!(sm.counts(), (4, 0));
        // Repeats and wrong sequences are neither OK nor ERROR: they push
        // OKs out of the window; VALID needs one OK.
        for _ in 0..3 {
            assert_eq!(sm.check(S::Repeated), SmState::Valid);
        }
        assert_eq!(sm.check(S::WrongSequence), SmState::Invalid);
        // INIT with too many errors goes INVALID.
        let mut sm = StateMachine::new(SM);
        sm.check(S::Ok);
        assert_eq!(sm.check(S::Error), SmState::Init);
        assert_eq!(sm.check(S::Error), SmState::Invalid);
    }

    #[test]
    fn window_size_is_clamped() {
        let mut sm = StateMachine::new(SmConfig {
            window_size: 0,
            min_ok_state_init: 1,
            ..SM
        });
        sm.check(CheckStatus::Ok);
        assert_eq!(sm.check(CheckStatus::Ok), SmState::Valid);
        let big = StateMachine::new(SmConfig {
            window_size: 200,
            ..SM
        });
        assert_eq!(big.cfg.window_size as usize, MAX_WINDOW);
    }

    #[test]
    fn receiver_chains_check_mapping_and_state_machine() {
        let mut r = Receiver::new(p01(1, 0), SM);
        let c = r.check(Some(&frame(3)));
        assert_eq!(
            (c.p01, c.status, c.state),
            (
                P01Status::Initial,
                CheckStatus::WrongSequence,
                SmState::Init
            )
        );
        r.check(Some(&frame(4)));
        let c = r.check(Some(&frame(5)));
        assert_eq!((c.status, c.state), (CheckStatus::Ok, SmState::Valid));
        r.check(Some(&corrupt(6)));
        let c = r.check(Some(&corrupt(6)));
        assert_eq!((c.status, c.state), (CheckStatus::Error, SmState::Invalid));
        assert_eq!(r.state(), SmState::Invalid);
        // An application-level refusal is an ERROR too.
        let mut r = Receiver::new(p01(1, 0), SM);
        r.check(Some(&frame(3)));
        r.reject();
        assert_eq!(r.reject(), SmState::Invalid);
    }
}
