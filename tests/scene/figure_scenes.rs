//! The scenes of the material and MIS figures (tools/gen_scenes.py): cornell-materials.gltf and
//! veach-mis.gltf hold the geometry, lights, materials and camera they claim, and every plate of
//! Veach's scene mirrors every light towards the camera with nothing in the way.

use glam::Vec3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use wavetrace::lights::emitted_power;
use wavetrace::scene::{Scene, Triangle};

fn path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

fn load(name: &str) -> Scene {
    Scene::load(&path(name)).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The glTF document itself, for the metallic-roughness factors that `Scene` does not hold.
fn document(name: &str) -> gltf::Document {
    gltf::Gltf::open(path(name))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .document
}

fn centroid(t: &Triangle) -> Vec3 {
    (t.p[0] + t.p[1] + t.p[2]) / 3.0
}

fn unit_normal(t: &Triangle) -> Vec3 {
    t.geometric_normal().normalize()
}

/// The scene's triangles grouped by material index, in material order.
fn by_material(scene: &Scene) -> BTreeMap<u32, Vec<Triangle>> {
    let mut groups: BTreeMap<u32, Vec<Triangle>> = BTreeMap::new();
    for t in &scene.triangles {
        groups.entry(t.material).or_default().push(*t);
    }
    groups
}

/// Centre of the bounding box of a point-symmetric mesh (an icosphere) and its largest distance
/// from that centre.
fn centre_and_radius(triangles: &[Triangle]) -> (Vec3, f32) {
    let points = triangles.iter().flat_map(|t| t.p);
    let (lo, hi) = points.clone().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    );
    let centre = (lo + hi) / 2.0;
    let radius = points.map(|p| (p - centre).length()).fold(0.0, f32::max);
    (centre, radius)
}

/// Ray parameter of the hit of `origin + s·direction` with `t` (Möller & Trumbore 1997).
fn intersect(origin: Vec3, direction: Vec3, t: &Triangle) -> Option<f32> {
    let (e1, e2) = (t.p[1] - t.p[0], t.p[2] - t.p[0]);
    let q = direction.cross(e2);
    let det = e1.dot(q);
    if det.abs() < 1e-12 {
        return None;
    }
    let r = origin - t.p[0];
    let u = r.dot(q) / det;
    let w = r.cross(e1);
    let v = direction.dot(w) / det;
    let s = e2.dot(w) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && s > 1e-4).then_some(s)
}

/// Index and distance of the closest triangle the ray hits.
fn closest_hit(scene: &Scene, origin: Vec3, direction: Vec3) -> Option<(usize, f32)> {
    scene
        .triangles
        .iter()
        .enumerate()
        .filter_map(|(i, t)| intersect(origin, direction, t).map(|s| (i, s)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

#[test]
fn figure_scenes_use_only_what_the_loader_reads() {
    for name in ["cornell-materials.gltf", "veach-mis.gltf"] {
        let scene = load(name);
        assert!(scene.notes.is_empty(), "{name}: {:?}", scene.notes);
        assert_eq!(document(name).extensions_required().count(), 0, "{name}");
    }
}

#[test]
fn cornell_materials_has_copper_box_glass_sphere_and_the_cornell_light() {
    let scene = load("cornell-materials.gltf");
    // Walls 10, light 2, tall box 12, icosphere of subdivision 3.
    assert_eq!(scene.triangles.len(), 10 + 2 + 12 + 1280);
    assert_eq!(scene.dropped_degenerate, 0);
    assert_eq!(scene.camera, load("cornell-box.gltf").camera);

    let named = |name: &str| -> Vec<Triangle> {
        let index = scene.materials.iter().position(|m| m.name == name);
        let index = index.unwrap_or_else(|| panic!("no material {name:?}")) as u32;
        scene
            .triangles
            .iter()
            .filter(|t| t.material == index)
            .copied()
            .collect()
    };
    let radiance = Vec3::new(18.387, 13.9873, 6.75357);
    let lights: Vec<_> = scene
        .triangles
        .iter()
        .filter(|t| scene.materials[t.material as usize].is_emissive())
        .collect();
    assert_eq!(lights.len(), 2);
    for t in lights {
        let e = scene.materials[t.material as usize].emission;
        assert!(
            ((e - radiance) / radiance).abs().max_element() < 1e-5,
            "{e}"
        );
    }

    let copper = named("rough copper");
    assert_eq!(copper.len(), 12);
    let box_centre = Vec3::new(-0.33, -0.4, -0.28);
    for t in &copper {
        assert!(unit_normal(t).dot(centroid(t) - box_centre) > 0.0, "{t:?}");
    }

    let glass = named("glass");
    assert_eq!(glass.len(), 1280);
    let (centre, radius) = centre_and_radius(&glass);
    assert!(
        (centre - Vec3::new(0.335, -0.7, 0.38)).length() < 1e-5,
        "{centre}"
    );
    assert!((radius - 0.3).abs() < 1e-5, "{radius}");
    let lowest = glass
        .iter()
        .flat_map(|t| t.p)
        .map(|p| p.y)
        .fold(0.0, f32::min);
    assert!((lowest + 1.0).abs() < 1e-5, "sphere bottom at y = {lowest}");
    for t in &glass {
        assert!(
            unit_normal(t).dot(centroid(t) - centre) > 0.0,
            "inward {t:?}"
        );
    }

    for m in document("cornell-materials.gltf").materials() {
        let pbr = m.pbr_metallic_roughness();
        let expected = match m.name() {
            Some("rough copper") => (1.0, 0.3),
            Some("glass") => (0.0, 0.0),
            _ => (0.0, 1.0),
        };
        assert_eq!((pbr.metallic_factor(), pbr.roughness_factor()), expected);
    }
}

/// Plate i (0 nearest the camera) and its roughness; lights as (x, radius) at y = 4.5, z = −0.5.
const PLATE_ROUGHNESS: [f32; 4] = [0.35, 0.2, 0.1, 0.05];
const LIGHTS: [(f32, f32); 4] = [(-3.6, 0.03), (-1.2, 0.1), (1.2, 0.3), (3.6, 0.9)];

/// Veach's scene: (plates, lights) as triangle groups, plates near to far, lights left to right.
fn veach_groups(scene: &Scene) -> (Vec<Vec<Triangle>>, Vec<Vec<Triangle>>) {
    let (lights, mut plates): (Vec<_>, Vec<_>) = by_material(scene)
        .into_iter()
        .partition(|(m, _)| scene.materials[*m as usize].is_emissive());
    plates.sort_by(|a, b| centroid(&b.1[0]).z.total_cmp(&centroid(&a.1[0]).z));
    let strip = |groups: Vec<(u32, Vec<Triangle>)>| groups.into_iter().map(|g| g.1).collect();
    (strip(plates), strip(lights))
}

#[test]
fn veach_mis_has_four_equal_power_lights_four_plates_and_the_camera() {
    let scene = load("veach-mis.gltf");
    assert_eq!(scene.triangles.len(), 4 * 2 + 2 * 320 + 2 * 1280);
    assert_eq!(scene.dropped_degenerate, 0);
    let (plates, lights) = veach_groups(&scene);

    assert_eq!(lights.len(), 4);
    let target = 4.0 * std::f32::consts::PI.powi(2);
    for (light, (x, r)) in lights.iter().zip(LIGHTS) {
        let (centre, radius) = centre_and_radius(light);
        assert!(
            (centre - Vec3::new(x, 4.5, -0.5)).length() < 1e-5,
            "{centre}"
        );
        assert!((radius - r).abs() < 1e-6 * r.max(1.0), "{radius} vs {r}");
        let m = &scene.materials[light[0].material as usize];
        assert_eq!((m.base_color, m.double_sided), (Vec3::ZERO, false));
        let power: f32 = light
            .iter()
            .map(|t| emitted_power(m.emission, t.area(), m.double_sided))
            .sum();
        assert!(
            (power / target - 1.0).abs() < 1e-4,
            "light at x = {x}: {power} W"
        );
        for t in light {
            assert!(
                unit_normal(t).dot(centroid(t) - centre) > 0.0,
                "inward {t:?}"
            );
        }
    }

    assert_eq!(plates.len(), 4);
    for (i, plate) in plates.iter().enumerate() {
        assert_eq!(plate.len(), 2);
        let area: f32 = plate.iter().map(Triangle::area).sum();
        assert!((area - 8.0).abs() < 1e-4, "plate {i}: area {area}");
        if i > 0 {
            assert!(
                centroid(&plate[0]).y > centroid(&plates[i - 1][0]).y,
                "plate {i} not higher"
            );
        }
    }
    let doc = document("veach-mis.gltf");
    for (plate, roughness) in plates.iter().zip(PLATE_ROUGHNESS) {
        let m = doc.materials().nth(plate[0].material as usize).unwrap();
        let pbr = m.pbr_metallic_roughness();
        assert_eq!(
            (pbr.metallic_factor(), pbr.roughness_factor()),
            (1.0, roughness)
        );
    }

    let cam = scene.camera;
    let pitch = (-17.5f32).to_radians();
    assert!((cam.position - Vec3::new(0.0, 5.0, 11.0)).length() < 1e-6);
    assert!((cam.forward - Vec3::new(0.0, pitch.sin(), -pitch.cos())).length() < 1e-6);
    assert!((cam.right - Vec3::X).length() < 1e-6);
    assert!((cam.yfov().unwrap() - 44f32.to_radians()).abs() < 1e-6);
    assert_eq!(cam.aspect_ratio(), Some(1.6));
}

/// For every plate and light, the point of the plate where the camera sees the light's centre
/// mirrored (the plane crossing of the line from the camera's mirror image to the light) lies on
/// the plate, in front of the camera with nothing in between, and the mirrored ray reaches that
/// light first. Every light is also in view directly.
#[test]
fn veach_plates_mirror_every_light_to_the_camera() {
    let scene = load("veach-mis.gltf");
    let (plates, lights) = veach_groups(&scene);
    let camera = scene.camera.position;
    let hits_group = |origin: Vec3, towards: Vec3, group: &[Triangle]| {
        let direction = (towards - origin).normalize();
        closest_hit(&scene, origin, direction)
            .is_some_and(|(i, _)| group.contains(&scene.triangles[i]))
    };
    for (l, light) in lights.iter().enumerate() {
        let (centre, _) = centre_and_radius(light);
        assert!(hits_group(camera, centre, light), "light {l} hidden");
        for (p, plate) in plates.iter().enumerate() {
            let n = unit_normal(&plate[0]);
            let origin = plate[0].p[0];
            let mirrored_camera = camera - 2.0 * (camera - origin).dot(n) * n;
            let (a, b) = ((mirrored_camera - origin).dot(n), (centre - origin).dot(n));
            assert!(
                a < 0.0 && b > 0.0,
                "plate {p} faces away from light {l} or the camera"
            );
            let m = mirrored_camera + (centre - mirrored_camera) * (a / (a - b));
            assert!(
                hits_group(camera, m, plate),
                "plate {p}: the camera does not see the mirror point {m} of light {l}"
            );
            let d = (m - camera).normalize();
            let reflected = d - 2.0 * d.dot(n) * n;
            let hit = closest_hit(&scene, m, reflected).map(|(i, _)| scene.triangles[i]);
            assert!(
                hit.is_some_and(|t| light.contains(&t)),
                "plate {p}: the mirror ray from {m} misses light {l}"
            );
        }
    }
}
