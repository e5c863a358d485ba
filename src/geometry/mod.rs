//! Geometry: shapes, their ray intersection, robust ray offsets and the BVH over them.

pub mod bvh;
pub mod offset;
pub mod order;
pub mod packet;
pub mod shapes;
pub mod tracer;
pub mod wbvh;

pub use bvh::{Accel, Traversal};
pub use shapes::{Primitive, Shape, NO_LIGHT};
