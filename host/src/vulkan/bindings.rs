//! A pass's set 0 as a struct of named fields ([`crate::bindings!`]), checked against the
//! kernel's own declaration ([`super::reflect`]) when the pipeline is created.

use super::{BindingKind, Buffer, Image, Resource};
use ash::vk;

/// One binding the host declares: the kernel parameter's name and what the host binds to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeclaredBinding {
    /// The kernel parameter's name.
    pub name: &'static str,
    /// What the host binds.
    pub kind: BindingKind,
}

/// A kernel's set 0 as the host binds it: named fields, in the kernel's binding order. Written
/// with [`crate::bindings!`].
pub trait Bindings {
    /// The fields' names and kinds, in order.
    const DECLARED: &'static [DeclaredBinding];
    /// The fields' resources, in order.
    fn resources(&self) -> Vec<Resource<'_>>;
}

/// A field type of a [`Bindings`] struct: what it binds, and as what.
pub trait BindingField: Copy {
    /// The binding kind it fills.
    const KIND: BindingKind;
    /// The resource bound.
    fn resource<'a>(self) -> Resource<'a>
    where
        Self: 'a;
}

impl BindingField for &Buffer {
    const KIND: BindingKind = BindingKind::StorageBuffer;
    fn resource<'a>(self) -> Resource<'a>
    where
        Self: 'a,
    {
        Resource::Buffer(self)
    }
}

impl BindingField for &Image {
    const KIND: BindingKind = BindingKind::StorageImage;
    fn resource<'a>(self) -> Resource<'a>
    where
        Self: 'a,
    {
        Resource::Image(self)
    }
}

/// A sampled image's view read by texel fetch, in `layout` whenever the dispatch runs.
#[derive(Clone, Copy, Debug)]
pub struct Sampled {
    /// The view.
    pub view: vk::ImageView,
    /// Its layout.
    pub layout: vk::ImageLayout,
}

impl BindingField for Sampled {
    const KIND: BindingKind = BindingKind::SampledImage;
    fn resource<'a>(self) -> Resource<'a> {
        Resource::SampledImage {
            view: self.view,
            layout: self.layout,
        }
    }
}

/// Declares a kernel's set-0 bindings as a struct with one public field per kernel parameter,
/// named as the parameter and in its order: `&Buffer` for a storage buffer, `&Image` for a
/// storage image, [`Sampled`] for a sampled image.
///
/// ```ignore
/// gi_host::bindings! {
///     /// TraceRays's set 0.
///     pub struct TraceRays<'a> { rays: &'a Buffer, hits: &'a Buffer }
/// }
/// ```
#[macro_export]
macro_rules! bindings {
    ($(#[$meta:meta])* $vis:vis struct $name:ident<$a:lifetime> {
        $($(#[$field_meta:meta])* $field:ident: $ty:ty),* $(,)?
    }) => {
        $(#[$meta])*
        #[derive(Clone, Copy)]
        $vis struct $name<$a> {
            $($(#[$field_meta])* pub $field: $ty,)*
        }

        impl<$a> $crate::vulkan::Bindings for $name<$a> {
            const DECLARED: &'static [$crate::vulkan::DeclaredBinding] = &[$(
                $crate::vulkan::DeclaredBinding {
                    name: stringify!($field),
                    kind: <$ty as $crate::vulkan::BindingField>::KIND,
                },
            )*];
            fn resources(&self) -> Vec<$crate::vulkan::Resource<'_>> {
                vec![$($crate::vulkan::BindingField::resource(self.$field),)*]
            }
        }
    };
}
