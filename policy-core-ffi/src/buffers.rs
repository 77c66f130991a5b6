//! The caller's pointers and lengths, checked before they become slices: NULL, misaligned, a
//! length past the address space, and overlapping buffers each give their code. The one file
//! where a raw pointer becomes a reference to a caller's buffer.

use crate::status::{
    Failure, DCP_ERR_BAD_LENGTH, DCP_ERR_MISALIGNED, DCP_ERR_NULL_POINTER, DCP_ERR_OVERLAP,
};

/// A checked raw buffer: its address range, before it becomes a slice.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Raw<T> {
    ptr: *const T,
    len: usize,
    name: &'static str,
}

impl<T> Raw<T> {
    /// `len` values of `T` from `ptr` (the argument `name`): refuses NULL, a pointer misaligned
    /// for `T`, and a range that does not fit the address space (or Rust's `isize::MAX` slice
    /// limit).
    pub(crate) fn new(ptr: *const T, len: usize, name: &'static str) -> Result<Self, Failure> {
        if ptr.is_null() {
            return Err(Failure::api(DCP_ERR_NULL_POINTER, name));
        }
        if !ptr.is_aligned() {
            return Err(Failure::api(DCP_ERR_MISALIGNED, name));
        }
        let fits = len
            .checked_mul(size_of::<T>())
            .filter(|&bytes| bytes <= isize::MAX as usize)
            .and_then(|bytes| (ptr as usize).checked_add(bytes))
            .is_some();
        if !fits {
            return Err(Failure::api(DCP_ERR_BAD_LENGTH, name));
        }
        Ok(Raw { ptr, len, name })
    }

    /// `len` values of `T` from `ptr` as [`Raw::new`], except that NULL with `len` 0 is an empty
    /// buffer (an absent optional region, such as a board's missing second slot).
    pub(crate) fn optional(ptr: *const T, len: usize, name: &'static str) -> Result<Self, Failure> {
        if ptr.is_null() && len == 0 {
            let ptr = core::ptr::NonNull::<T>::dangling().as_ptr().cast_const();
            return Ok(Raw { ptr, len: 0, name });
        }
        Raw::new(ptr, len, name)
    }

    /// The pointer.
    pub(crate) fn ptr(&self) -> *const T {
        self.ptr
    }

    /// The byte range `[start, end)` the buffer covers.
    fn range(&self) -> (usize, usize) {
        let start = self.ptr as usize;
        (start, start + self.len * size_of::<T>())
    }

    /// Refuses `self` and `other` overlapping (two empty buffers never do).
    pub(crate) fn disjoint<U>(&self, other: &Raw<U>) -> Result<(), Failure> {
        let ((a0, a1), (b0, b1)) = (self.range(), other.range());
        if a0 < b1 && b0 < a1 {
            return Err(Failure::api(
                DCP_ERR_OVERLAP,
                overlap_name(self.name, other.name),
            ));
        }
        Ok(())
    }

    /// The buffer as a shared slice.
    ///
    /// # Safety
    /// The caller's contract: `ptr` points to `len` initialised values of `T` that nothing
    /// writes while the slice lives (`'a`).
    pub(crate) unsafe fn slice<'a>(self) -> &'a [T] {
        // SAFETY: `new` checked non-NULL, alignment and a size within isize::MAX that does not
        // wrap the address space; the caller vouches for the memory itself.
        unsafe { core::slice::from_raw_parts(self.ptr, self.len) }
    }

    /// The buffer as a mutable slice.
    ///
    /// # Safety
    /// As [`Raw::slice`], and the memory is writable and no other reference to it lives while
    /// the slice does (the callers check `disjoint` against every other argument).
    pub(crate) unsafe fn slice_mut<'a>(self) -> &'a mut [T] {
        // SAFETY: as in `slice`; exclusivity is the caller's promise, checked against the
        // other arguments with `disjoint`.
        unsafe { core::slice::from_raw_parts_mut(self.ptr.cast_mut(), self.len) }
    }
}

impl<T> Raw<T> {
    /// Writes `value` to a checked pointer to one `T` (from [`one`]).
    ///
    /// # Safety
    /// The memory is writable, and no reference to it lives (the callers check `disjoint`).
    pub(crate) unsafe fn put(self, value: T) {
        if self.len >= 1 {
            // SAFETY: non-NULL and aligned (checked in `new`), room for one `T` (len >= 1),
            // writable and unaliased by the caller's contract; `write` reads nothing old.
            unsafe { self.ptr.cast_mut().write(value) };
        }
    }
}

/// A checked pointer to one `T` (an out-argument or a model's storage).
pub(crate) fn one<T>(ptr: *const T, name: &'static str) -> Result<Raw<T>, Failure> {
    Raw::new(ptr, 1, name)
}

/// The `what` of an overlap: the two argument names (a fixed set, so a static string each).
fn overlap_name(a: &'static str, b: &'static str) -> &'static str {
    match (a, b) {
        ("scratch", "obs") | ("obs", "scratch") => "scratch and obs",
        ("scratch", "action") | ("action", "scratch") => "scratch and action",
        ("action", "obs") | ("obs", "action") => "action and obs",
        ("scratch", "unit_action") | ("unit_action", "scratch") => "scratch and unit_action",
        ("codes", "obs") | ("obs", "codes") => "codes and obs",
        ("scratch", "codes") | ("codes", "scratch") => "scratch and codes",
        ("unit_codes", "codes") | ("codes", "unit_codes") => "unit_codes and codes",
        ("scratch", "unit_codes") | ("unit_codes", "scratch") => "scratch and unit_codes",
        ("model", _) | (_, "model") => "the model's storage and another buffer",
        ("out", _) | (_, "out") => "out and another buffer",
        _ => "two buffers",
    }
}
