//! Scratch memory kept per thread from call to call: a hot loop's arrays that it rewrites
//! before reading them, taken from the thread instead of zeroed on every call.

use std::cell::Cell;
use std::ops::{Deref, DerefMut};
use std::thread::LocalKey;

/// The slot of a thread's kept value of type `T`: a `thread_local!` of this type.
pub(crate) type Slot<T> = Cell<Option<Box<T>>>;

/// A value taken from a thread's [`Slot`] for a while and put back when dropped. The
/// value holds what the last holder left in it: the holder must write whatever it reads.
/// Taken while another is out (or first on a thread), it is made afresh by `make`.
pub(crate) struct Kept<T: 'static> {
    slot: &'static LocalKey<Slot<T>>,
    value: Option<Box<T>>,
}

impl<T: 'static> Kept<T> {
    /// This thread's value in `slot`, or `make()` when it has none.
    #[inline]
    pub(crate) fn take(slot: &'static LocalKey<Slot<T>>, make: impl FnOnce() -> T) -> Kept<T> {
        let value = slot.take().unwrap_or_else(|| Box::new(make()));
        Kept { slot, value: Some(value) }
    }
}

impl<T: 'static> Deref for Kept<T> {
    type Target = T;
    #[inline]
    fn deref(&self) -> &T {
        self.value.as_deref().expect("a kept value is held until dropped")
    }
}

impl<T: 'static> DerefMut for Kept<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut T {
        self.value.as_deref_mut().expect("a kept value is held until dropped")
    }
}

impl<T: 'static> Drop for Kept<T> {
    fn drop(&mut self) {
        self.slot.set(self.value.take());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        static SLOT: Slot<[u32; 4]> = const { Cell::new(None) };
    }

    #[test]
    fn a_kept_value_comes_back_as_it_was_left_and_a_second_holder_gets_its_own() {
        {
            let mut a = Kept::take(&SLOT, || [0; 4]);
            a[1] = 7;
            // Taken while `a` is out: made afresh.
            let b = Kept::take(&SLOT, || [9; 4]);
            assert_eq!(*b, [9; 4]);
            assert_eq!(*a, [0, 7, 0, 0]);
            // `b` goes back first, then `a` replaces it.
        }
        assert_eq!(*Kept::take(&SLOT, || [0; 4]), [0, 7, 0, 0]);
        // Another thread has its own.
        std::thread::spawn(|| assert_eq!(*Kept::take(&SLOT, || [1; 4]), [1; 4])).join().unwrap();
    }
}
