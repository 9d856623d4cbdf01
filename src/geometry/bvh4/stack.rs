//! The traversal stack: uninitialised storage on the machine stack, or on the heap
//! for trees too deep for that.

use std::mem::MaybeUninit;

/// Entries an on-stack traversal stack holds; deeper trees use a heap stack.
pub(super) const STACK: usize = 192;

/// Binds `$buf` to traversal stack storage for `$tree`: on the machine stack, or on
/// the heap when the tree is too deep for that. (A macro rather than a function
/// taking the kernel as a closure, which measured 3% more instructions.)
macro_rules! stack_buffer {
    ($tree:expr, $buf:ident) => {
        let mut items = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut heap;
        let $buf: &mut [_] = if $tree.stack_len > STACK {
            heap = heap_stack($tree.stack_len);
            &mut heap
        } else {
            &mut items
        };
    };
}
pub(super) use stack_buffer;

#[derive(Clone, Copy)]
pub(super) struct Entry {
    pub(super) child: u32,
    pub(super) t: f32,
}

/// A traversal stack; `Bvh4::stack_len` bounds how deep it gets.
pub(super) struct Stack<'a> {
    items: &'a mut [MaybeUninit<Entry>],
    pub(super) len: usize,
}

impl<'a> Stack<'a> {
    #[inline(always)]
    pub(super) fn new(items: &'a mut [MaybeUninit<Entry>]) -> Self {
        Stack { items, len: 0 }
    }

    #[inline(always)]
    pub(super) fn push(&mut self, child: u32, t: f32) {
        self.items[self.len] = MaybeUninit::new(Entry { child, t });
        self.len += 1;
    }

    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<Entry> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: every slot below `len` was written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }

    #[inline(always)]
    pub(super) fn get(&self, i: usize) -> Entry {
        debug_assert!(i < self.len);
        // SAFETY: callers only read below `len`, and those slots were pushed.
        unsafe { self.items[i].assume_init() }
    }

    #[inline(always)]
    pub(super) fn set(&mut self, i: usize, e: Entry) {
        self.items[i] = MaybeUninit::new(e);
    }
}

#[cold]
#[inline(never)]
pub(super) fn heap_stack(len: usize) -> Vec<MaybeUninit<Entry>> {
    vec![MaybeUninit::uninit(); len]
}
