//! The shapes a scene file's values take (a number, a whole number, an
//! array of exactly N numbers, a table, an array of tables), each
//! deserialised so that a wrong shape is refused in the file's own terms.
//!
//! serde's own impls name Rust types in their errors ("expected f64",
//! "expected struct SpringsTable", "expected a sequence"), silently drop
//! the extra elements of a fixed-length array, and let a derived struct be
//! written as an array of its fields in declaration order. These wrappers
//! say what the TOML must look like instead, and accept nothing else.

use std::fmt;
use std::marker::PhantomData;

use serde::de::value::MapAccessDeserializer;
use serde::de::{self, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

/// How a value of a type is written in a scene file, for the "expected …"
/// half of a message.
pub(super) trait Form {
    /// One value, with its article: "a number", "a `[wind]` table".
    const ONE: &'static str;
    /// Several values, as an array's elements: "numbers", "`[[sphere]]`
    /// tables".
    const MANY: &'static str;
}

/// A number (TOML integer or float); range checks are `validate`'s.
#[derive(Clone, Copy)]
pub(super) struct Number(pub(super) f64);

impl Form for Number {
    const ONE: &'static str = "a number";
    const MANY: &'static str = "numbers";
}

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct NumberVisitor;
        impl Visitor<'_> for NumberVisitor {
            type Value = Number;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(Number::ONE)
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Number, E> {
                Ok(Number(x))
            }
            // An integer is read as the nearest f64, as a float literal is.
            fn visit_i64<E: de::Error>(self, i: i64) -> Result<Number, E> {
                Ok(Number(i as f64))
            }
            fn visit_u64<E: de::Error>(self, i: u64) -> Result<Number, E> {
                Ok(Number(i as f64))
            }
            // TOML integers beyond 64 bits, which the toml crate reads.
            fn visit_i128<E: de::Error>(self, i: i128) -> Result<Number, E> {
                Ok(Number(i as f64))
            }
            fn visit_u128<E: de::Error>(self, i: u128) -> Result<Number, E> {
                Ok(Number(i as f64))
            }
        }
        d.deserialize_any(NumberVisitor)
    }
}

/// The unsigned types a [`Whole`] number is read into.
pub(super) trait Count: TryFrom<u64> {
    /// The largest value the type holds.
    const MAX: u64;
}

impl Count for u32 {
    const MAX: u64 = u32::MAX as u64;
}

impl Count for u64 {
    const MAX: u64 = u64::MAX;
}

impl Count for usize {
    const MAX: u64 = usize::MAX as u64;
}

/// A whole number ≥ 0 that fits `T` (a count: particles, iterations);
/// range checks are `validate`'s.
#[derive(Clone, Copy)]
pub(super) struct Whole<T>(pub(super) T);

impl<T> Form for Whole<T> {
    const ONE: &'static str = "a whole number ≥ 0";
    const MANY: &'static str = "whole numbers";
}

impl<'de, T: Count> Deserialize<'de> for Whole<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct WholeVisitor<T>(PhantomData<T>);
        impl<T: Count> Visitor<'_> for WholeVisitor<T> {
            type Value = Whole<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(Whole::<T>::ONE)
            }
            fn visit_u64<E: de::Error>(self, i: u64) -> Result<Whole<T>, E> {
                // The representable limit, far above every count's own
                // range (which `validate` then states).
                T::try_from(i).map(Whole).map_err(|_| {
                    E::custom(format!(
                        "{i} is too large: expected a whole number ≤ {}",
                        T::MAX
                    ))
                })
            }
            fn visit_i64<E: de::Error>(self, i: i64) -> Result<Whole<T>, E> {
                match u64::try_from(i) {
                    Ok(i) => self.visit_u64(i),
                    Err(_) => Err(E::invalid_value(de::Unexpected::Signed(i), &self)),
                }
            }
            // Beyond 64 bits: too large, or negative.
            fn visit_u128<E: de::Error>(self, i: u128) -> Result<Whole<T>, E> {
                Err(E::custom(format!(
                    "{i} is too large: expected a whole number ≤ {}",
                    T::MAX
                )))
            }
            fn visit_i128<E: de::Error>(self, i: i128) -> Result<Whole<T>, E> {
                match u128::try_from(i) {
                    Ok(i) => self.visit_u128(i),
                    Err(_) => Err(E::custom(format!(
                        "invalid value: integer `{i}`, expected {}",
                        Whole::<T>::ONE
                    ))),
                }
            }
        }
        d.deserialize_any(WholeVisitor(PhantomData))
    }
}

/// An array of exactly `N` values: `[1, 2]` where `[x, y]` is expected;
/// fewer or more elements are refused, never padded or truncated.
pub(super) struct Exactly<T, const N: usize>(pub(super) [T; N]);

impl<'de, T: Form + Deserialize<'de>, const N: usize> Deserialize<'de> for Exactly<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct ExactlyVisitor<T, const N: usize>(PhantomData<T>);
        impl<'de, T: Form + Deserialize<'de>, const N: usize> Visitor<'de> for ExactlyVisitor<T, N> {
            type Value = Exactly<T, N>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "an array of exactly {N} {}", T::MANY)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut values = Vec::with_capacity(N);
                while values.len() < N {
                    match seq.next_element::<T>()? {
                        Some(v) => values.push(v),
                        None => break,
                    }
                }
                // Extra elements are counted whatever their type, so the
                // message gives the real length.
                let mut count = values.len();
                while seq.next_element::<IgnoredAny>()?.is_some() {
                    count += 1;
                }
                match <[T; N]>::try_from(values) {
                    Ok(array) if count == N => Ok(Exactly(array)),
                    _ => Err(de::Error::custom(format!(
                        "expected exactly {N} {}, got {count}",
                        T::MANY
                    ))),
                }
            }
        }
        d.deserialize_seq(ExactlyVisitor::<T, N>(PhantomData))
    }
}

/// Any number of values: `[a, b, …]`, or for tables `[[name]]` blocks.
pub(super) struct List<T>(pub(super) Vec<T>);

impl<T> Default for List<T> {
    fn default() -> Self {
        List(Vec::new())
    }
}

impl<'de, T: Form + Deserialize<'de>> Deserialize<'de> for List<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct ListVisitor<T>(PhantomData<T>);
        impl<'de, T: Form + Deserialize<'de>> Visitor<'de> for ListVisitor<T> {
            type Value = List<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "an array of {}", T::MANY)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut values = Vec::new();
                while let Some(v) = seq.next_element()? {
                    values.push(v);
                }
                Ok(List(values))
            }
        }
        d.deserialize_seq(ListVisitor(PhantomData))
    }
}

/// A TOML table (`[name]` with its keys below it, or `{ key = … }`) holding
/// the derived struct `T`; every other shape is refused, an array of
/// values included.
#[derive(Default)]
pub(super) struct Table<T>(pub(super) T);

impl<T: Form> Form for Table<T> {
    const ONE: &'static str = T::ONE;
    const MANY: &'static str = T::MANY;
}

impl<'de, T: Form + Deserialize<'de>> Deserialize<'de> for Table<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct TableVisitor<T>(PhantomData<T>);
        impl<'de, T: Form + Deserialize<'de>> Visitor<'de> for TableVisitor<T> {
            type Value = Table<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(T::ONE)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                T::deserialize(MapAccessDeserializer::new(map)).map(Table)
            }
        }
        d.deserialize_map(TableVisitor(PhantomData))
    }
}

/// One table (`[name]`) or an array of them (`[[name]]`): the values in
/// order, and whether the file wrote an array (its keys are then named
/// `name[i].key`).
pub(super) struct OneOrMany<T> {
    pub(super) values: Vec<T>,
    pub(super) many: bool,
}

impl<T: Default> Default for OneOrMany<T> {
    fn default() -> Self {
        OneOrMany {
            values: vec![T::default()],
            many: false,
        }
    }
}

impl<'de, T: Form + Deserialize<'de>> Deserialize<'de> for OneOrMany<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct OneOrManyVisitor<T>(PhantomData<T>);
        impl<'de, T: Form + Deserialize<'de>> Visitor<'de> for OneOrManyVisitor<T> {
            type Value = OneOrMany<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}, or {}", T::ONE, T::MANY)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                let one = T::deserialize(MapAccessDeserializer::new(map))?;
                Ok(OneOrMany {
                    values: vec![one],
                    many: false,
                })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut values = Vec::new();
                while let Some(Table(v)) = seq.next_element::<Table<T>>()? {
                    values.push(v);
                }
                if values.is_empty() {
                    return Err(de::Error::invalid_length(0, &self));
                }
                Ok(OneOrMany { values, many: true })
            }
        }
        d.deserialize_any(OneOrManyVisitor(PhantomData))
    }
}
