//! Handles: what a C caller holds is never a pointer to Rust memory but an encoded slot number
//! (kind, generation, index) in a registry. A freed, double-freed, never-made or other kind's
//! handle is refused by a lookup, never dereferenced; a slot reused after a free carries a new
//! generation, so a stale handle to it is refused too.

use std::sync::{Arc, Mutex, PoisonError, RwLock};

/// Which registry a handle belongs to (the top byte of a handle).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Kernel = 0x5a,
    Trial = 0x5b,
    Assignment = 0x5c,
    Builder = 0x5d,
}

/// The largest generation (24 bits): a slot that reaches it is retired, never reused, so a
/// generation never repeats for a slot.
const MAX_GENERATION: u32 = (1 << 24) - 1;

struct Slot<T> {
    generation: u32,
    value: Option<Arc<Mutex<T>>>,
}

struct Slab<T> {
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
}

/// The live handles of one kind.
pub(crate) struct Registry<T> {
    kind: Kind,
    slab: RwLock<Slab<T>>,
}

/// Why a lookup failed.
pub(crate) enum Lookup {
    /// NULL.
    Null,
    /// Not a live handle of this kind.
    Dead,
}

impl<T> Registry<T> {
    pub(crate) const fn new(kind: Kind) -> Self {
        Registry {
            kind,
            slab: RwLock::new(Slab {
                slots: Vec::new(),
                free: Vec::new(),
            }),
        }
    }

    /// Registers `value`; returns its handle (never 0).
    pub(crate) fn insert(&self, value: T) -> usize {
        let mut slab = self.slab.write().unwrap_or_else(PoisonError::into_inner);
        let value = Some(Arc::new(Mutex::new(value)));
        let index = match slab.free.pop() {
            Some(i) => {
                let slot = &mut slab.slots[i as usize];
                slot.generation += 1;
                slot.value = value;
                i
            }
            None => {
                slab.slots.push(Slot {
                    generation: 0,
                    value,
                });
                // More than 2^32 live handles cannot be encoded: a caller leaking handles
                // that fast runs out of memory first.
                u32::try_from(slab.slots.len() - 1).unwrap_or(u32::MAX)
            }
        };
        let generation = slab.slots[index as usize].generation;
        encode(self.kind, generation, index)
    }

    /// The value behind `handle`, if it is a live handle of this kind.
    pub(crate) fn get(&self, handle: usize) -> Result<Arc<Mutex<T>>, Lookup> {
        if handle == 0 {
            return Err(Lookup::Null);
        }
        let (kind, generation, index) = decode(handle);
        if kind != self.kind as u8 {
            return Err(Lookup::Dead);
        }
        let slab = self.slab.read().unwrap_or_else(PoisonError::into_inner);
        match slab.slots.get(index as usize) {
            Some(Slot {
                generation: g,
                value: Some(v),
            }) if *g == generation => Ok(Arc::clone(v)),
            _ => Err(Lookup::Dead),
        }
    }

    /// Unregisters `handle`; the value is dropped once no call holds it any more.
    pub(crate) fn remove(&self, handle: usize) -> Result<(), Lookup> {
        if handle == 0 {
            return Err(Lookup::Null);
        }
        let (kind, generation, index) = decode(handle);
        if kind != self.kind as u8 {
            return Err(Lookup::Dead);
        }
        let removed = {
            let mut slab = self.slab.write().unwrap_or_else(PoisonError::into_inner);
            let removed = match slab.slots.get_mut(index as usize) {
                Some(slot) if slot.generation == generation && slot.value.is_some() => {
                    slot.value.take()
                }
                _ => return Err(Lookup::Dead),
            };
            if generation < MAX_GENERATION {
                slab.free.push(index);
            }
            removed
        };
        // Dropped outside the registry's lock: a value's drop may take time (a journal's file).
        drop(removed);
        Ok(())
    }
}

fn encode(kind: Kind, generation: u32, index: u32) -> usize {
    ((kind as u64) << 56 | u64::from(generation) << 32 | (u64::from(index) + 1)) as usize
}

fn decode(handle: usize) -> (u8, u32, u32) {
    let h = handle as u64;
    let index = (h & 0xffff_ffff) as u32;
    (
        (h >> 56) as u8,
        ((h >> 32) & 0xff_ffff) as u32,
        index.wrapping_sub(1),
    )
}

#[cfg(not(target_pointer_width = "64"))]
compile_error!("savme-capi encodes handles in 64-bit pointers");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_foreign_and_null_handles_are_refused() {
        let r: Registry<u32> = Registry::new(Kind::Trial);
        let other: Registry<u32> = Registry::new(Kind::Kernel);
        let a = r.insert(1);
        assert!(r.get(a).is_ok());
        assert!(matches!(other.get(a), Err(Lookup::Dead)));
        assert!(matches!(r.get(0), Err(Lookup::Null)));
        r.remove(a).ok().unwrap();
        assert!(matches!(r.get(a), Err(Lookup::Dead)));
        assert!(matches!(r.remove(a), Err(Lookup::Dead)));
        // The slot is reused with a new generation: the stale handle stays refused.
        let b = r.insert(2);
        assert_ne!(a, b);
        assert!(matches!(r.get(a), Err(Lookup::Dead)));
        assert_eq!(*r.get(b).ok().unwrap().lock().unwrap(), 2);
        assert!(matches!(r.get(a ^ 0x40), Err(Lookup::Dead)));
    }
}
