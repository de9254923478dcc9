//! What the device keeps in flash, with `sequential-storage` on any
//! `embedded-storage-async` NorFlash (embassy-stm32's flash on the board, a
//! RAM flash in tests):
//!
//! - a **map** (its own flash range) with the parameter set in two slots,
//!   keys 0 and 1 (version counter `v` goes to slot `v % 2`), and the boot
//!   counter (key 2). A slot's value is `version u32 ‖ crc32 u32 ‖
//!   encoding` (little-endian); the encoding is the postcard encoding of
//!   `monitor::Params`. Boot takes the valid slot with the highest version
//!   (item CRC of the map, our CRC, decodes, `Params::validate`), else the
//!   compiled-in default (version 0). An upload writes only the slot that
//!   does not hold the active set, so a power cut at any moment leaves the
//!   active set intact: sequential-storage appends and only erases a page
//!   after copying its live items;
//! - a **queue** (its own flash range) of [`EventRecord`]s, oldest first;
//!   when full, the oldest page is erased (the queue keeps at least all
//!   pages but one).
//!
//! Erasing a page stalls the STM32F405 (single flash bank: every
//! instruction fetch waits, 0.25–2 s per sector), so erases happen only
//! out of service, at boot and during an upload ([`Erase::Allowed`]). In
//! service, an event is appended only where no erase is needed
//! ([`Erase::Never`]); at boot the queue moves to a fresh page when fewer
//! than [`EVENT_RESERVE`] bytes are left, so that in-service events find
//! room.

use crate::frame::CRC32;
use crate::message::{EventRecord, ParamsId, MAX_EVENT_BYTES};
use core::ops::Range;
use embedded_storage_async::nor_flash::NorFlash;
use monitor::Params;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};
use sequential_storage::queue::{QueueConfig, QueueStorage};

/// Largest parameter encoding the device stores, bytes.
pub const PARAMS_MAX: usize = 1536;
/// Header of a stored slot: version and CRC.
const SLOT_HEADER: usize = 8;
/// Map buffer: key, slot, word alignment.
const BUF: usize = PARAMS_MAX + SLOT_HEADER + 40;
/// Map key of the boot counter.
const BOOT_KEY: u8 = 2;
/// Bytes of event queue that boot leaves free for in-service appends
/// (about 25 events, each stored in 32–40 bytes with its header).
pub const EVENT_RESERVE: usize = 1024;

/// May a storage operation erase a flash page?
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Erase {
    /// Yes: out of service (boot, an upload).
    Allowed,
    /// No: in service, where a stalled core would miss its deadlines.
    Never,
}

/// The canonical encoding of `p` in `out`.
pub fn encode_params<'o>(p: &Params, out: &'o mut [u8]) -> Option<&'o [u8]> {
    postcard::to_slice(p, out).ok().map(|s| &*s)
}

/// A parameter set from its canonical encoding (every byte used).
pub fn decode_params(bytes: &[u8]) -> Option<Params> {
    match postcard::take_from_bytes::<Params>(bytes) {
        Ok((p, [])) => Some(p),
        _ => None,
    }
}

/// The identity of `p` stored as `version` (None: its encoding does not
/// fit [`PARAMS_MAX`]). Encodes on the stack (`PARAMS_MAX` bytes).
pub fn params_identity(p: &Params, version: u32) -> Option<ParamsId> {
    let mut buf = [0u8; PARAMS_MAX];
    encode_params(p, &mut buf).map(|enc| params_id(enc, version))
}

/// The identity of the encoding `enc` stored as `version`.
pub fn params_id(enc: &[u8], version: u32) -> ParamsId {
    ParamsId {
        version,
        crc: CRC32.checksum(enc),
    }
}

/// The parameter set in use.
#[derive(Clone, Debug, PartialEq)]
pub struct Loaded {
    /// The set.
    pub params: Params,
    /// Its identity.
    pub id: ParamsId,
    /// Read from flash (false: the compiled-in default).
    pub stored: bool,
}

/// A storage operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// The flash driver failed (or power went).
    Flash,
    /// The storage found its data corrupted beyond repair.
    Corrupted,
    /// Too large for the storage.
    TooLarge,
    /// The set read back differs from the one written.
    ReadBack,
    /// Storing it needs a page erase, and erases were not allowed.
    NeedsErase,
    /// Any other error of the storage crate.
    Other,
}

impl<E> From<sequential_storage::Error<E>> for StoreError {
    fn from(e: sequential_storage::Error<E>) -> Self {
        use sequential_storage::Error as S;
        match e {
            S::Storage { .. } => Self::Flash,
            S::Corrupted { .. } => Self::Corrupted,
            S::FullStorage | S::ItemTooBig | S::BufferTooSmall(_) | S::BufferTooBig => {
                Self::TooLarge
            }
            _ => Self::Other,
        }
    }
}

type NoCache<K> = Cache<Uncached, Uncached, Uncached, K>;

/// The device's flash storage.
pub struct Storage<P: NorFlash, E: NorFlash> {
    params: MapStorage<u8, P, NoCache<u8>>,
    events: QueueStorage<E, NoCache<()>>,
    buf: [u8; BUF],
    slot: [u8; PARAMS_MAX + SLOT_HEADER],
}

impl<P: NorFlash, E: NorFlash> Storage<P, E> {
    /// Parameters in `params_range` of `params_flash`, events in
    /// `events_range` of `events_flash` (ranges on erase-page boundaries;
    /// the map needs two pages or more, the queue one or more).
    ///
    /// # Panics
    /// On ranges sequential-storage cannot use (a configuration error).
    pub fn new(
        params_flash: P,
        params_range: Range<u32>,
        events_flash: E,
        events_range: Range<u32>,
    ) -> Self {
        Self {
            params: MapStorage::new(
                params_flash,
                MapConfig::new(params_range),
                Cache::new_uncached(),
            ),
            events: QueueStorage::new(
                events_flash,
                QueueConfig::new(events_range),
                Cache::new_uncached(),
            ),
            buf: [0; BUF],
            slot: [0; PARAMS_MAX + SLOT_HEADER],
        }
    }

    /// Give the flashes back.
    pub fn into_flash(self) -> (P, E) {
        (self.params.destroy().0, self.events.destroy().0)
    }

    /// The newest valid stored set, else `default` (version 0).
    pub async fn load_params(&mut self, default: &Params) -> Loaded {
        let mut best: Option<Loaded> = None;
        for key in [0u8, 1] {
            let Ok(Some(rec)) = self.params.fetch_item::<&[u8]>(&mut self.buf, &key).await else {
                continue;
            };
            let Some(cand) = parse_slot(rec) else {
                continue;
            };
            if best.as_ref().is_none_or(|b| cand.id.version > b.id.version) {
                best = Some(cand);
            }
        }
        best.unwrap_or_else(|| {
            let enc = encode_params(default, &mut self.buf).unwrap_or(&[]);
            Loaded {
                params: default.clone(),
                id: params_id(enc, 0),
                stored: false,
            }
        })
    }

    /// Store the encoding `enc` as the set after `active`, read it back and
    /// return its identity. `active`'s slot is not touched.
    pub async fn store_params(
        &mut self,
        enc: &[u8],
        active: ParamsId,
    ) -> Result<ParamsId, StoreError> {
        if enc.len() > PARAMS_MAX {
            return Err(StoreError::TooLarge);
        }
        let id = params_id(enc, active.version.wrapping_add(1).max(1));
        let key = (id.version % 2) as u8;
        let n = SLOT_HEADER + enc.len();
        self.slot[..4].copy_from_slice(&id.version.to_le_bytes());
        self.slot[4..8].copy_from_slice(&id.crc.to_le_bytes());
        self.slot[8..n].copy_from_slice(enc);
        let rec: &[u8] = &self.slot[..n];
        self.params.store_item(&mut self.buf, &key, &rec).await?;
        match self.params.fetch_item::<&[u8]>(&mut self.buf, &key).await? {
            Some(back) if back == &self.slot[..n] => Ok(id),
            _ => Err(StoreError::ReadBack),
        }
    }

    /// Increment the boot counter and return it (1 at the first boot). A
    /// failure leaves the old count (returned + 1, not stored).
    pub async fn bump_boot(&mut self) -> u32 {
        let old = match self
            .params
            .fetch_item::<u32>(&mut self.buf, &BOOT_KEY)
            .await
        {
            Ok(Some(n)) => n,
            _ => 0,
        };
        let new = old.wrapping_add(1);
        let _ = self.params.store_item(&mut self.buf, &BOOT_KEY, &new).await;
        new
    }

    /// Append an event, erasing the oldest page for room only if `erase`
    /// allows it (else [`StoreError::NeedsErase`]). When this returns
    /// `Ok`, the event is in flash.
    pub async fn append_event(&mut self, ev: &EventRecord, erase: Erase) -> Result<(), StoreError> {
        let mut bytes = [0u8; MAX_EVENT_BYTES];
        let n = postcard::to_slice(ev, &mut bytes)
            .map_err(|_| StoreError::TooLarge)?
            .len();
        self.push_event(&bytes[..n], erase).await
    }

    /// Bytes of event items (each with its few bytes of header) that can
    /// be appended before the queue needs an erase, at least: the rest of
    /// its current page, or a whole page when the next one is erased.
    pub async fn event_room(&mut self) -> Result<usize, StoreError> {
        Ok(self.events.find_max_fit().await?.unwrap_or(0) as usize)
    }

    /// Out of service: append `ev`, and when fewer than [`EVENT_RESERVE`]
    /// bytes are left before the queue would need an erase, store it
    /// padded past them, so that it starts a freshly erased page now and
    /// in-service events find room later. (The padding is zeros after
    /// the record, which its decoding ignores.)
    pub async fn append_event_making_room(&mut self, ev: &EventRecord) -> Result<(), StoreError> {
        let fit = self.event_room().await?;
        let whole_page = E::ERASE_SIZE - 2 * E::WRITE_SIZE.max(E::READ_SIZE);
        if fit >= EVENT_RESERVE || fit >= whole_page {
            return self.append_event(ev, Erase::Allowed).await;
        }
        // Longer than what fits: the queue moves on to the next page.
        let padded = (fit + 1).max(MAX_EVENT_BYTES).min(self.slot.len());
        self.slot[..padded].fill(0);
        postcard::to_slice(ev, &mut self.slot[..MAX_EVENT_BYTES])
            .map_err(|_| StoreError::TooLarge)?;
        let (events, slot) = (&mut self.events, &self.slot);
        events.push(&slot[..padded], true).await?;
        Ok(())
    }

    async fn push_event(&mut self, bytes: &[u8], erase: Erase) -> Result<(), StoreError> {
        match self.events.push(bytes, erase == Erase::Allowed).await {
            Ok(()) => Ok(()),
            Err(sequential_storage::Error::FullStorage) if erase == Erase::Never => {
                Err(StoreError::NeedsErase)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Events oldest first: skip `skip`, then fill `out` up to its
    /// capacity. Returns the number stored.
    pub async fn read_events<const N: usize>(
        &mut self,
        skip: u32,
        out: &mut heapless::Vec<EventRecord, N>,
    ) -> Result<u32, StoreError> {
        let mut total = 0u32;
        let mut it = self.events.iter().await?;
        while let Some(entry) = it.next(&mut self.buf).await? {
            // Items are CRC-checked by the storage; an item this firmware
            // cannot decode is skipped, not counted.
            let Ok(ev) = postcard::from_bytes::<EventRecord>(&entry) else {
                continue;
            };
            if total >= skip {
                let _ = out.push(ev);
            }
            total += 1;
        }
        Ok(total)
    }
}

/// A stored slot, if it is intact and valid.
fn parse_slot(rec: &[u8]) -> Option<Loaded> {
    if rec.len() < SLOT_HEADER {
        return None;
    }
    let version = u32::from_le_bytes(rec[..4].try_into().ok()?);
    let crc = u32::from_le_bytes(rec[4..8].try_into().ok()?);
    let enc = &rec[SLOT_HEADER..];
    let id = params_id(enc, version);
    if id.crc != crc || version == 0 {
        return None;
    }
    let params = decode_params(enc)?;
    params.validate().ok()?;
    Some(Loaded {
        params,
        id,
        stored: true,
    })
}
