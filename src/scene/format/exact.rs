//! `deserialize_with` functions that read a fixed-length array of numbers whole and
//! refuse any other length, naming the field. serde reads `[f32; N]` by taking N
//! elements and stopping, and the `toml` crate's array deserializer does not check that
//! the array ended (toml_edit's `ArraySeqAccess`), so a file's `shutter = [0, 1, 0.5]`
//! used to be read as `[0, 1]` while the same value through `--set` (serde's own
//! sequence deserializer) was refused. One function per field name, because a tagged
//! table (`[[objects]]`) is buffered before it is read and its errors carry no position
//! inside it: the message has to name the field itself.

use serde::de::{Deserialize, Deserializer, Error};

/// Exactly `N` numbers; the message names `field`.
fn numbers<'de, D: Deserializer<'de>, const N: usize>(d: D, field: &str) -> Result<[f32; N], D::Error> {
    let v = Vec::<f32>::deserialize(d)?;
    let n = v.len();
    v.try_into().map_err(|_| D::Error::custom(format!("`{field}` takes {N} numbers, not {n}")))
}

macro_rules! fields {
    ($($name:ident: $n:literal),* $(,)?) => {$(
        #[doc = concat!("`", stringify!($name), "`: exactly ", stringify!($n), " numbers.")]
        pub(super) fn $name<'de, D: Deserializer<'de>>(d: D) -> Result<[f32; $n], D::Error> {
            numbers(d, stringify!($name))
        }
    )*};
}

fields!(
    up: 3, shutter: 2, color: 3, specular: 3, color0: 3, color1: 3, corner: 3, edge_u: 3, edge_v: 3,
    radiance: 3, v0: 3, v1: 3, v2: 3, position: 3, intensity: 3, center: 3, translate: 3, scale: 3,
    axis: 3, origin: 3, target: 3, direction: 3, irradiance: 3,
);

/// The optional fields: present, they are read as the others are.
pub(super) mod opt {
    use serde::de::{Deserialize, Deserializer, Error};

    macro_rules! optional {
        ($($name:ident),* $(,)?) => {$(
            #[doc = concat!("`", stringify!($name), "`: exactly 3 numbers when given.")]
            pub(in super::super) fn $name<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f32; 3]>, D::Error> {
                super::numbers(d, stringify!($name)).map(Some)
            }
        )*};
    }

    optional!(position, look_at, eta, k, emission, color);

    /// `uv`: exactly three pairs of numbers when given.
    pub(in super::super) fn uv<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[[f32; 2]; 3]>, D::Error> {
        let v = Vec::<Vec<f32>>::deserialize(d)?;
        let n = v.len();
        let pairs: [Vec<f32>; 3] =
            v.try_into().map_err(|_| D::Error::custom(format!("`uv` takes 3 pairs of numbers, not {n}")))?;
        let mut out = [[0.0; 2]; 3];
        for (i, (pair, o)) in pairs.into_iter().zip(&mut out).enumerate() {
            let n = pair.len();
            *o = pair.try_into().map_err(|_| D::Error::custom(format!("`uv.{i}` takes 2 numbers, not {n}")))?;
        }
        Ok(Some(out))
    }
}
