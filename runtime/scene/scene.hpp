#pragma once
// The scene file mat-run reads: a JSON document of time settings, gravity, solver settings,
// objects (a bake each, placed, with a material and pinned regions), colliders and output.
// Every key is declared once, with its type, default and doc, in the table of
// runtime/scene/scene_schema.cpp; the parser and scene_reference_markdown() are driven by it.
// The defaults live in that table only: a Scene is meant to come from parse_scene(), which
// fills every field.
//
// Units are SI. Pin regions are in the bake's coordinates (before the object is placed).
// Bake paths in the file are relative to the scene file's directory; a parsed Scene holds them
// absolute and normalized.

#include <optional>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

struct TimeSettings {
    double dt = 0.0; ///< time step, s
    /// output frames after the initial one. After parsing: the effective count (derived from
    /// time.duration when that is given), equal to Scene::frames.
    int frames = 0;
    std::optional<double> duration; ///< s, as given (frames is derived from it)
    std::optional<double> fps; ///< output frames per second, as given
    int iterations = 0; ///< PD local/global iterations per step (the most, with a tolerance)
    double tolerance = 0.0; ///< SolverOptions::tolerance (0: fixed iteration count)
};

/// The local step's decomposition (SolverOptions::exact_projections).
enum class ProjectionMode { fast, exact };
/// Which bodies keep angular momentum (SolverOptions::angular_momentum), in the order of the
/// scene's choices.
enum class AngularMomentumMode { free, keep, integrator };
/// The PD iteration within a step (SolverOptions::acceleration).
enum class AccelerationMode { none, anderson };
enum class DeviceMode { cpu, cuda };
/// A choice that defaults by the solver mode ("auto") or is set for every mode: enabled (the
/// key's second choice: "iterate", "on") or disabled (its third: "step", "off").
enum class ModeChoice { automatic, enabled, disabled };
/// Collision between objects: medial bounds enlarged to enclose the deformed surface, moved
/// only, or none (runtime/collision/collision_world.hpp).
enum class CollisionMode { bounded, lazy, off };
/// What moves an object: its simulation, nothing, or a prescribed rigid motion.
enum class ObjectMotion { dynamic, static_, kinematic };
/// The scene's word for `motion`: "dynamic", "static" or "kinematic".
const char* motion_name(ObjectMotion motion);

struct SolverSettings {
    double damping = 0.0; ///< per-step velocity scaling in [0, 1)
    double volume_tolerance = 0.0; ///< det F kept in [1 - tol, 1 + tol]
    ProjectionMode projections = ProjectionMode::fast; ///< "fast" or "exact"
    AccelerationMode acceleration = AccelerationMode::none; ///< "none" or "anderson"
    DeviceMode device = DeviceMode::cpu; ///< "cpu" or "cuda" (the semi-reduced step on a GPU)
    /// "free", "keep" or "integrator" (SolverOptions::angular_momentum)
    AngularMomentumMode angular_momentum = AngularMomentumMode::keep;
    int anderson_window = 0; ///< differences kept by Anderson acceleration
    double contact_margin = 0.0; ///< contact candidate distance, relative to the bake's size
    CollisionMode collision = CollisionMode::bounded; ///< "bounded", "lazy" or "off"
    bool self_collision = true; ///< "on" or "off"
    bool edge_contacts = false; ///< "on" or "off": edge-edge contacts besides vertex-face
    bool compliance_preload = true; ///< "on" or "off" (SolverOptions::compliance_preload)
    /// "auto" (step in full space, else iterate), "iterate" or "step"
    /// (SolverOptions::planes_follow_iterate)
    ModeChoice contact_normals = ModeChoice::automatic;
    /// "auto" (on in full space, else off), "on" or "off": contacts found again at the iterate
    /// halfway through a step (SolverOptions::detect_in_step; not in a step with a
    /// hyper-reduced object)
    ModeChoice detect_in_step = ModeChoice::automatic;
    /// "on" or "off": subspace steps in the contact solves (ContactSettings::subspace_every)
    bool contact_subspace = false;
    double collision_margin = 0.0; ///< relative to the largest bake's diagonal
    /// The gap contacts between objects keep, relative to the collision margin
    /// (SolverOptions::contact_skin)
    double contact_skin = 0.0;
    /// The gap a self contact keeps, relative to the collision margin, in every mode (0: none;
    /// CollisionSettings::self_skin)
    double self_skin = 0.5;
    /// The fastest a self contact pushes a vertex that starts a step behind its face back out,
    /// in rest bounding-box diagonals per second (SolverOptions::self_push_speed)
    double self_push_speed = 0.02;
    /// The most a contact between objects may sink by its compliance beyond the skin, relative
    /// to the smaller object's diagonal (SolverOptions::compliance_cap)
    double compliance_cap = 0.0;
    double collision_friction = 0.0; ///< Coulomb coefficient between objects
    /// A dynamic object sleeps after sleep_steps steps with every node slower than sleep_speed
    /// x its rest bounding-box diagonal per second; 0 = never.
    double sleep_speed = 0.0;
    int sleep_steps = 0; ///< consecutive slow steps before an object sleeps
    int hyper_samples = 0; ///< tets in the hyper-reduced local step (0: automatic)
    double reduced_pin_stiffness = 0.0; ///< ModelOptions::pin_weight_scale of reduced bodies
    double full_pin_stiffness = 0.0; ///< ModelOptions::pin_weight_scale of full-space bodies
};

struct MaterialSettings {
    double youngs_modulus = 0.0; ///< E, Pa
    double poisson_ratio = 0.0; ///< nu in [0, 0.5)
    double density = 0.0; ///< kg / m^3
    std::optional<Vec2> strain_limits; ///< [min, max] singular values, 0 <= min <= 1 <= max
};

enum class PinKind { box, sphere, nodes };

struct PinBox {
    Vec3 min = Vec3::Zero();
    Vec3 max = Vec3::Zero(); ///< componentwise >= min
};

struct PinSphere {
    Vec3 center = Vec3::Zero();
    double radius = 0.0; ///< > 0
};

/// One keyframe of a prescribed rigid motion: of a pin region, or of a kinematic object (see
/// pin_motion.hpp).
struct PinKeyframe {
    double time = 0.0; ///< s, strictly increasing along the list
    Vec3 translation = Vec3::Zero(); ///< displacement of the region, m
    Vec3 rotation_degrees = Vec3::Zero(); ///< XYZ Euler angles about the region's rest centroid
};

/// A pinned region of an object: exactly one of box, sphere or nodes (told by `kind`).
struct PinRegion {
    PinKind kind = PinKind::box;
    PinBox box; ///< when kind == box: the nodes inside the closed box
    PinSphere sphere; ///< when kind == sphere: the nodes inside the closed ball
    std::vector<int> nodes; ///< when kind == nodes: tet-mesh node indices (>= 0, not yet
                            ///< checked against the bake)
    std::vector<PinKeyframe> motion; ///< empty = the region stays at rest
};

struct ObjectSettings {
    std::string name; ///< unique among the objects
    ObjectMotion motion = ObjectMotion::dynamic; ///< "dynamic", "static" or "kinematic"
    std::string bake; ///< absolute, normalized path of the bake file
    Vec3 position = Vec3::Zero(); ///< translation applied after the rotation, m
    /// XYZ Euler angles, degrees: rotate about x, then y, then z, about the bake's origin
    /// (see rotation_from_euler_degrees in pin_motion.hpp)
    Vec3 rotation_degrees = Vec3::Zero();
    Vec3 velocity = Vec3::Zero(); ///< initial velocity, m/s
    Vec3 angular_velocity = Vec3::Zero(); ///< initial, rad/s, about the centre of mass
    MaterialSettings material;
    std::vector<PinRegion> pins; ///< none on a kinematic object
    /// Kinematic objects: keyframes of the rigid motion relative to the placement (rotation about
    /// the placed centre of mass); empty = constant velocity and angular_velocity.
    std::vector<PinKeyframe> keyframes;
};

/// A collider's shape (one kind for now).
enum class ColliderType { plane };

struct ColliderSettings {
    ColliderType type = ColliderType::plane; ///< "plane"
    Vec3 point = Vec3::Zero(); ///< a point of the plane
    Vec3 normal = Vec3::UnitY(); ///< unit length (normalized by the parser)
    double friction = 0.0; ///< Coulomb coefficient, >= 0
};

/// A frame file format (runtime/output/exporter.hpp).
enum class OutputFormat { obj, ply, vtu, h5 };
/// An extra per-vertex field of vtu and h5 frames.
enum class OutputField { velocity, stretch };

struct OutputSettings {
    std::vector<OutputFormat> formats; ///< distinct: "obj", "ply", "vtu", "h5"
    /// steps per output frame. After parsing: the effective value (derived from time.fps when
    /// that is given), equal to Scene::steps_per_frame.
    int every = 0;
    std::vector<OutputField> fields; ///< distinct: "velocity", "stretch"
};

struct Scene {
    std::string file; ///< the scene path, as given (for messages)
    TimeSettings time;
    Vec3 gravity = Vec3::Zero(); ///< m/s^2
    SolverSettings solver;
    std::vector<ObjectSettings> objects; ///< at least one
    std::vector<ColliderSettings> colliders;
    OutputSettings output;

    int steps_per_frame = 0; ///< derived: time steps per output frame, >= 1
    int frames = 0; ///< derived: output frames after the initial one, >= 1
    double frame_interval() const { return steps_per_frame * time.dt; } ///< s between frames
};

struct SceneOptions {
    /// Check that every bake file exists (off only for tools and tests that look at a scene
    /// without its bakes; paths are resolved either way).
    bool check_files = true;
};

/// Whether the scene's bodies take contacts from one another or from themselves: collision is
/// not off, and there are two or more objects or self collision is on.
bool scene_collides(const Scene& scene);

/// Reads and checks the scene at `path`. Throws mat::Error with one line naming the file and,
/// for a JSON syntax error, the line and column, else the key path (e.g.
/// `objects[1].material.poisson_ratio`) and the problem: unknown key, wrong type, value out of
/// range, missing required key, missing bake file, or inconsistent time settings.
Scene read_scene(const std::string& path, const SceneOptions& options = {});

/// The same on JSON text in memory. `path_for_messages` names the file in messages and is the
/// scene path that relative bake paths are resolved against (its directory).
Scene parse_scene(const std::string& json_text, const std::string& path_for_messages,
    const SceneOptions& options = {});

/// One declared key, as the reference shows it.
struct SceneKeyInfo {
    std::string section; ///< e.g. "" (top level), "time", "objects[]", "objects[].pins[].box"
    std::string key; ///< e.g. "dt"
    std::string type; ///< e.g. "number > 0"
    std::string default_value; ///< e.g. "1/60", "required", "none"
    std::string doc; ///< one line
};

/// Every declared key, in table order.
std::vector<SceneKeyInfo> scene_keys();

/// The Markdown reference of the scene format: one table per section (key, type, default, doc).
std::string scene_reference_markdown();

} // namespace mat
