//! Code compiled for the size of a small model: the dispatch on its DOF count
//! ([`by_size`]) and the vectors kept inline at that size ([`Inline`]), shared by DOP853 and
//! the Newmark family.

/// `$body` with the constant `$n` the model's DOF count `$size` for the small models (1 to
/// 4 DOFs) and 0 for the others (`$body` calls an `#[inline(always)]` function generic over
/// `$n`, [`dofs`]): the small models' loops over the DOFs unroll and their working vectors
/// are arrays of their size ([`Inline`]): a 2-DOF rotor's DOP853 evaluations cost a quarter
/// less. DOP853 and the Newmark family dispatch on it.
macro_rules! by_size {
    ($size:expr, |$n:ident| $body:expr) => {
        match $size {
            1 => {
                const $n: usize = 1;
                $body
            }
            2 => {
                const $n: usize = 2;
                $body
            }
            3 => {
                const $n: usize = 3;
                $body
            }
            4 => {
                const $n: usize = 4;
                $body
            }
            _ => {
                const $n: usize = 0;
                $body
            }
        }
    };
}

/// The DOF count of code compiled for `N` DOFs ([`by_size`]; `N = 0`: any, `len`).
#[inline(always)]
pub(crate) fn dofs<const N: usize>(len: usize) -> usize {
    if N > 0 {
        N
    } else {
        len
    }
}

pub(crate) use by_size;

/// The step a stepper compiled by [`by_size`] takes for a model of `n_dof` DOFs
/// ([`crate::output::Stats::step_path`]).
pub(crate) fn sized_step_path(n_dof: usize) -> &'static str {
    match n_dof {
        1 => "fixed-size N=1",
        2 => "fixed-size N=2",
        3 => "fixed-size N=3",
        4 => "fixed-size N=4",
        _ => "general",
    }
}

/// The largest model whose values are kept inline ([`Inline`]): the sizes [`by_size`]
/// compiles for.
pub(crate) const MAX_SIZED: usize = 4;

/// `len` values (one per component: a DOF's, or its row of stage values): inline (at a
/// constant place in their owner) for up to [`MAX_SIZED`], where the code compiled for `N` of
/// them takes the first `N` at a constant count ([`Self::sized`]), else on the heap. Read and
/// written as a slice otherwise (`Deref`: general code takes the slice once, not per access,
/// which would test the length each time).
pub struct Inline<T> {
    inline: [T; MAX_SIZED],
    heap: Vec<T>,
    len: usize,
}

impl<T: Copy> Inline<T> {
    pub(crate) fn new(len: usize, zero: T) -> Self {
        Self {
            inline: [zero; MAX_SIZED],
            heap: if len > MAX_SIZED {
                vec![zero; len]
            } else {
                Vec::new()
            },
            len,
        }
    }

    /// The values, for code compiled for `N` components ([`by_size`]; `N = 0`: all of them,
    /// inline or not, so that the general code also takes a small model).
    #[inline(always)]
    pub(crate) fn sized<const N: usize>(&self) -> &[T] {
        if N > 0 {
            &self.inline[..N]
        } else {
            self
        }
    }

    #[inline(always)]
    pub(crate) fn sized_mut<const N: usize>(&mut self) -> &mut [T] {
        if N > 0 {
            &mut self.inline[..N]
        } else {
            self
        }
    }
}

impl<T: Copy + Default> From<&[T]> for Inline<T> {
    fn from(values: &[T]) -> Self {
        let mut held = Self::new(values.len(), T::default());
        held.copy_from_slice(values);
        held
    }
}

impl<T: Clone> Clone for Inline<T> {
    fn clone(&self) -> Self {
        Self {
            inline: self.inline.clone(),
            heap: self.heap.clone(),
            len: self.len,
        }
    }

    /// Into the heap values' allocation, as `Vec::clone_from` (a large model's state is
    /// copied every step).
    fn clone_from(&mut self, source: &Self) {
        self.inline.clone_from(&source.inline);
        self.heap.clone_from(&source.heap);
        self.len = source.len;
    }
}

/// Equal values (whatever their place).
impl<T: PartialEq> PartialEq for Inline<T> {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

/// As the slice (a `State`'s vectors print as they did when they were `Vec`s).
impl<T: std::fmt::Debug> std::fmt::Debug for Inline<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

impl<T> std::ops::Deref for Inline<T> {
    type Target = [T];

    #[inline]
    fn deref(&self) -> &[T] {
        if self.len <= MAX_SIZED {
            &self.inline[..self.len]
        } else {
            &self.heap
        }
    }
}

impl<T> std::ops::DerefMut for Inline<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut [T] {
        if self.len <= MAX_SIZED {
            &mut self.inline[..self.len]
        } else {
            &mut self.heap
        }
    }
}

impl<'a, T> IntoIterator for &'a Inline<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}
