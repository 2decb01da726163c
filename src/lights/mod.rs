//! Everything that emits: the emitter table of emissive triangles and punctual lights with the
//! power CDF next event estimation samples (`emitters`), the light BVH that samples them by their
//! importance to a point instead (`light_bvh`), KHR_lights_punctual's lights (`punctual`) and
//! the environment map (`environment`) and the built-in studio environment that lights a file
//! without lights (`studio`, an ordinary map to the GPU), and the physical sky and sun of
//! `--sky` (`sky`, an ordinary map and a directional light). Each file but `studio` and `sky`
//! is the twin of the GLSL file of the same name in `shaders/inc/`.

pub mod emitters;
pub mod environment;
pub mod light_bvh;
pub mod punctual;
pub mod sky;
pub mod studio;

pub use emitters::{
    build_light_table, build_light_table_with, emitted_power, luminance, punctual_power,
    sample_light,
};
pub use environment::EnvironmentMap;
pub use punctual::{punctual_incident, punctual_intensity, punctual_window, spot_cos_outer};
pub use sky::{sky, SkyParams};
pub use studio::studio;
