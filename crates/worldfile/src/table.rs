//! The property-table macro: one declaration per model type gives the typed struct, its defaults,
//! the list of properties it reads and the function that reads them.
//!
//! Each row is `field: Type = default, reader(args);` where `reader` is a [`crate::reader::Reader`]
//! method. Reading marks properties used, so the "defined but not used" warning for a model is
//! exactly "not in any table this model's type reads". A field of type `Option<T>` is `None` when
//! the property is absent.

/// Assigns a read value to a field that is either `T` or `Option<T>`.
pub(crate) trait Assign<T> {
    fn assign(&mut self, value: T);
}

impl<T> Assign<T> for T {
    fn assign(&mut self, value: T) {
        *self = value;
    }
}

impl<T> Assign<T> for Option<T> {
    fn assign(&mut self, value: T) {
        *self = Some(value);
    }
}

macro_rules! property_table {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                $field:ident : $ty:ty = $default:expr ,
                    $method:ident $(::<$n:literal>)? ( $key:literal $(, $arg:expr)* ) ;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq, serde::Serialize)]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: $ty, )*
        }

        impl Default for $name {
            fn default() -> Self {
                $name { $( $field: $default, )* }
            }
        }

        impl $name {
            /// The worldfile properties this table reads, in reading order.
            pub const PROPERTIES: &'static [&'static str] = &[ $( $key ),* ];

            /// Reads every property of the table from the reader's entity, starting from the
            /// defaults.
            #[allow(dead_code)]
            pub(crate) fn read(
                r: &mut $crate::reader::Reader<'_, '_>,
            ) -> Result<Self, $crate::error::Error> {
                Self::read_from(r, Self::default())
            }

            /// Reads every property of the table, starting from `base` (a type's defaults).
            pub(crate) fn read_from(
                r: &mut $crate::reader::Reader<'_, '_>,
                base: Self,
            ) -> Result<Self, $crate::error::Error> {
                let mut s = base;
                $(
                    if let Some(v) = r.$method $(::<$n>)? ($key $(, $arg)*)? {
                        $crate::table::Assign::assign(&mut s.$field, v);
                    }
                )*
                Ok(s)
            }
        }
    };
}

pub(crate) use property_table;

/// An enum of worldfile words and the table a property table's `choice` reads it with, declared
/// once: each variant is written `Variant = "word"`, and serialises as its word.
macro_rules! word_enum {
    (
        $(#[$meta:meta])*
        pub enum $name:ident in $table:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $word:literal, )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
        pub enum $name {
            $( $(#[$vmeta])* #[serde(rename = $word)] $variant, )*
        }

        const $table: &[(&str, $name)] = &[ $( ($word, $name::$variant) ),* ];
    };
}

pub(crate) use word_enum;
