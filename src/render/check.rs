//! Why settings cannot be rendered on a scene, before any work starts: what light tracing and
//! BDPT do not (yet) take.

use super::prepared::PreparedScene;
use super::settings::Integrator;
use crate::layout::LIGHT_DIRECTIONAL;
use crate::mis::Heuristic;

/// Why `settings` cannot be rendered with `--integrator light|bdpt` on `scene`, if they cannot
/// (the path tracer takes everything).
pub fn check(
    scene: &PreparedScene,
    settings: &super::settings::RenderSettings,
) -> Result<(), String> {
    if settings.integrator == Integrator::Path {
        return Ok(());
    }
    let name = settings.integrator.name();
    let refuse = |why: &str| Err(format!("--integrator {name} {why}"));
    if scene.camera.is_orthographic() {
        return refuse("needs a perspective camera: light paths join a pinhole, and an orthographic camera has none (use --integrator path)");
    }
    if settings.aperture > 0.0 {
        return refuse("joins light paths to a pinhole: --aperture must be 0 (use --integrator path for depth of field)");
    }
    // Light from infinity needs origins on a disc beyond the scene and, for BDPT, camera
    // vertices that escape to it: not written yet.
    if settings.environment_map().is_some() {
        return refuse("does not start light paths at the environment yet: drop --env/--environment or use --integrator path");
    }
    if scene.punctual.iter().any(|l| l.kind == LIGHT_DIRECTIONAL) {
        return refuse("does not start light paths at directional lights yet (the scene has one): use --integrator path");
    }
    if settings.aov != crate::layout::AOV_RADIANCE {
        return refuse("records radiance only: --aov needs --integrator path");
    }
    if settings.integrator == Integrator::Bdpt
        && matches!(settings.mis, Heuristic::LightOnly | Heuristic::BsdfOnly)
    {
        return refuse(
            "weighs all its strategies: --mis must be power, balance, maximum or average",
        );
    }
    Ok(())
}
