#include "runtime/scene/scene_schema.hpp"

#include <algorithm>
#include <iterator>
#include <type_traits>

#include <fmt/format.h>

#include "common/error.hpp"
#include "runtime/pd/anderson.hpp"

namespace mat::scene_schema {

namespace {

    using Store = std::function<void(Target, const Value&)>;

    template <typename Member, typename V> void assign(Member& member, const V& value)
    {
        if constexpr (std::is_same_v<Member, V> || std::is_same_v<Member, std::optional<V>>)
            member = value;
        else
            MAT_CHECK(false, "scene schema: a key's value type does not match its member");
    }

    /// A key whose checked value is stored into `member` of the section's struct.
    template <typename S, typename M>
    KeySpec value_key(Section section, const char* name, Type type, M S::*member)
    {
        KeySpec key;
        key.section = section;
        key.name = name;
        key.type = type;
        key.store = [member](Target target, const Value& value) {
            S& object = *std::get<S*>(target);
            std::visit([&](const auto& v) { assign(object.*member, v); }, value);
        };
        return key;
    }

    /// The index of `text` in `choices` (which the parser has checked it is one of).
    int choice_index(const std::vector<std::string>& choices, const std::string& text)
    {
        const auto at = std::find(choices.begin(), choices.end(), text);
        MAT_CHECK(at != choices.end(), "scene schema: '{}' is not a choice of its key", text);
        return static_cast<int>(at - choices.begin());
    }

    /// A key of `type` (string or strings) restricted to `names`.
    KeySpec choice_key(
        Section section, const char* name, Type type, std::initializer_list<const char*> names)
    {
        KeySpec key;
        key.section = section;
        key.name = name;
        key.type = type;
        key.choices.assign(names.begin(), names.end());
        return key;
    }

    /// A string key with a fixed set of choices, stored into the enum (or bool) `member`: the
    /// i-th choice is the value i (for a bool: the first choice is true).
    template <typename S, typename E>
    KeySpec enum_key(
        Section section, const char* name, E S::*member, std::initializer_list<const char*> names)
    {
        static_assert(std::is_enum_v<E> || std::is_same_v<E, bool>);
        KeySpec key = choice_key(section, name, Type::string, names);
        key.store = [member, choices = key.choices](Target target, const Value& value) {
            const int index = choice_index(choices, std::get<std::string>(value));
            if constexpr (std::is_same_v<E, bool>)
                (*std::get<S*>(target)).*member = index == 0;
            else
                (*std::get<S*>(target)).*member = static_cast<E>(index);
        };
        return key;
    }

    /// A list of distinct strings from a fixed set of choices, stored into the vector of enums
    /// `member`: the i-th choice is the value i.
    template <typename S, typename E>
    KeySpec enum_list_key(Section section, const char* name, std::vector<E> S::*member,
        std::initializer_list<const char*> names)
    {
        static_assert(std::is_enum_v<E>);
        KeySpec key = choice_key(section, name, Type::strings, names);
        key.store = [member, choices = key.choices](Target target, const Value& value) {
            std::vector<E>& out = (*std::get<S*>(target)).*member;
            out.clear();
            for (const std::string& text : std::get<std::vector<std::string>>(value))
                out.push_back(static_cast<E>(choice_index(choices, text)));
        };
        return key;
    }

    /// A key whose value is a section that fills `member`. Absent sections are filled with
    /// their defaults unless set_default(nullptr) says the section is optional.
    template <typename S, typename M>
    KeySpec section_key(Section section, const char* name, Section child, M S::*member)
    {
        KeySpec key;
        key.section = section;
        key.name = name;
        key.type = Type::section;
        key.child = child;
        key.default_value = Json::object();
        key.open = [member](Target target) -> Target { return &((*std::get<S*>(target)).*member); };
        return key;
    }

    /// A key whose value is a list of sections, each appended to the vector `member`.
    template <typename S, typename E>
    KeySpec array_key(Section section, const char* name, Section child, std::vector<E> S::*member)
    {
        KeySpec key;
        key.section = section;
        key.name = name;
        key.type = Type::section_array;
        key.child = child;
        key.default_value = Json::array();
        key.open = [member](Target target) -> Target {
            return &((*std::get<S*>(target)).*member).emplace_back();
        };
        return key;
    }

    std::string check_not_empty(const Value& value)
    {
        return std::get<std::string>(value).empty() ? "must not be empty" : "";
    }

    std::string check_nonzero(const Value& value)
    {
        // The largest component, not the squared norm: that underflows to 0 for [1e-200, 0, 0].
        return std::get<Vec3>(value).cwiseAbs().maxCoeff() > 0.0 ? ""
                                                                 : "must not be the zero vector";
    }

    std::string check_strain_limits(const Value& value)
    {
        const Vec2& limits = std::get<Vec2>(value);
        if (limits[0] >= 0.0 && limits[0] <= 1.0 && limits[1] >= 1.0)
            return "";
        return fmt::format("[{}, {}] must satisfy 0 <= min <= 1 <= max", limits[0], limits[1]);
    }

    /// The top-level keys.
    std::vector<KeySpec> root_keys()
    {
        using S = Section;
        using T = Type;
        return { // Top level.
            section_key(S::root, "time", S::time, &Scene::time).set_doc("time stepping"),
            value_key(S::root, "gravity", T::vec3, &Scene::gravity)
                .set_default(Json::array({ 0, -9.81, 0 }))
                .set_doc("gravitational acceleration, m/s^2"),
            section_key(S::root, "solver", S::solver, &Scene::solver).set_doc("solver settings"),
            array_key(S::root, "objects", S::object, &Scene::objects)
                .set_required()
                .set_min_count(1)
                .set_doc("the deformable bodies, at least one"),
            array_key(S::root, "colliders", S::collider, &Scene::colliders)
                .set_doc("static colliders"),
            section_key(S::root, "output", S::output, &Scene::output)
                .set_doc("what is written, and how often")
        };
    }

    /// time: the time stepping.
    std::vector<KeySpec> time_keys()
    {
        using S = Section;
        using T = Type;
        return { // time
            value_key(S::time, "dt", T::number, &TimeSettings::dt)
                .set_default(1.0 / 60.0, "1/60")
                .above(0)
                .set_doc("time step h, s"),
            value_key(S::time, "frames", T::integer, &TimeSettings::frames)
                .set_default(60)
                .at_least(1)
                .set_doc("output frames after the initial one; not with duration"),
            value_key(S::time, "duration", T::number, &TimeSettings::duration)
                .above(0)
                .set_doc("simulated time, s: frames = round(duration * output frames per "
                         "second); not with frames"),
            value_key(S::time, "fps", T::number, &TimeSettings::fps)
                .above(0)
                .set_doc("output frames per second: steps per frame = 1 / (fps * dt), which "
                         "must be a whole number >= 1 (to 1e-6 relative); not with "
                         "output.every"),
            value_key(S::time, "iterations", T::integer, &TimeSettings::iterations)
                .set_default(10)
                .at_least(1)
                .set_doc("PD local/global iterations per step (with tolerance: the most)"),
            value_key(S::time, "tolerance", T::number, &TimeSettings::tolerance)
                .set_default(0.0)
                .at_least(0)
                .set_doc("0: every step runs `iterations`; else a step ends after the iteration "
                         "that follows one changing every object's iterate by less than this, "
                         "relative to its bounding-box diagonal (mass-weighted RMS; on the "
                         "reduced coordinates, the diagonal of the reduced mass; docs/method.md, "
                         "\"Iterations to a tolerance\"); not with --device cuda")
        };
    }

    /// solver: the solver, collision and sleeping settings.
    std::vector<KeySpec> solver_keys()
    {
        using S = Section;
        using T = Type;
        return { // solver
            value_key(S::solver, "damping", T::number, &SolverSettings::damping)
                .set_default(0)
                .at_least(0)
                .below(1)
                .set_doc("velocities are scaled by (1 - damping) after each step"),
            value_key(S::solver, "volume_tolerance", T::number, &SolverSettings::volume_tolerance)
                .set_default(0.01)
                .at_least(0)
                .below(1)
                .set_doc("volume constraints keep det F in [1 - tolerance, 1 + tolerance]"),
            enum_key(S::solver, "projections", &SolverSettings::projections, { "fast", "exact" })
                .set_default("fast")
                .set_doc("the local step's SVD: fast (float eigenvectors, exact at rest and under "
                         "rigid motion, about 1e-7 of the size off the exact trajectory) or exact "
                         "(double precision throughout, slower)"),
            enum_key(
                S::solver, "acceleration", &SolverSettings::acceleration, { "none", "anderson" })
                .set_default("none")
                .set_doc("the PD iterations of a step: plain, or Anderson-accelerated with a "
                         "safeguard (an extrapolated iterate that raises the PD energy, or with "
                         "--solver hyper the fixed-point residual, is replaced by the plain one); "
                         "a body's steps with contact candidates run plain (docs/method.md, "
                         "\"Accelerated iterations\")"),
            enum_key(S::solver, "device", &SolverSettings::device, { "cpu", "cuda" })
                .set_default("cpu")
                .set_doc("where the semi-reduced step runs: cpu, or cuda (a GPU; mat-run built "
                         "with -DMAT_CUDA=ON; --device overrides; docs/gpu.md)"),
            enum_key(S::solver, "angular_momentum", &SolverSettings::angular_momentum,
                { "free", "keep", "integrator" })
                .set_default("keep")
                .set_doc("free: an object without pins or contacts in a step ends it with its "
                         "start angular momentum (its internal forces exert no net moment; "
                         "implicit Euler alone loses a few percent per second under spin and "
                         "vibration); keep: also an object in contact whose contact island "
                         "(the simulated objects that pushed each other in the step, "
                         "transitively) has no object pushed by the ground, a static, "
                         "kinematic or sleeping object, or with pins, with the moments of their "
                         "impulses (kept through impacts between free objects; a pile on the "
                         "ground is held and settles as with free); "
                         "integrator: what implicit Euler and the iterations give "
                         "(docs/method.md, \"Angular momentum\"); --device cuda steps keep none"),
            value_key(S::solver, "anderson_window", T::integer, &SolverSettings::anderson_window)
                .set_default(5)
                .at_least(1)
                .at_most(anderson_max_window)
                .set_doc("iterate differences Anderson acceleration keeps (its window m)"),
            value_key(S::solver, "contact_margin", T::number, &SolverSettings::contact_margin)
                .set_default(0.01)
                .at_least(0)
                .set_doc("nodes this close to a plane (fraction of the bake's bounding-box "
                         "diagonal) are contact candidates for a step"),
            enum_key(
                S::solver, "collision", &SolverSettings::collision, { "bounded", "lazy", "off" })
                .set_default("bounded")
                .set_doc("collision between objects (and, with self_collision on, within one): "
                         "medial primitives enlarged to enclose the deformed surface (bounded), "
                         "moved only (lazy, can miss under large deformation), or none; a scene "
                         "of one object without self collision has none to detect"),
            enum_key(S::solver, "self_collision", &SolverSettings::self_collision, { "on", "off" })
                .set_default("on")
                .set_doc("collision between non-adjacent medial primitives of one object (with "
                         "collision on): without it a body's parts pass through each other, as "
                         "a pile's creatures did by 32 mm (docs/method.md, \"Self collision on "
                         "by default\")"),
            enum_key(S::solver, "edge_contacts", &SolverSettings::edge_contacts, { "on", "off" })
                .set_default("off")
                .set_doc("contacts between sharp surface edges (convex, their faces at least 20 "
                         "degrees apart at rest) that meet between their vertices, such as a "
                         "ridge across a ridge, besides those of a vertex against a face "
                         "(docs/method.md, \"Edge contacts\")"),
            enum_key(S::solver, "compliance_preload", &SolverSettings::compliance_preload,
                { "on", "off" })
                .set_default("on")
                .set_doc("a contact between objects that pressed in the last step keeps that "
                         "force free of the contacts' compliance, so that a steady contact "
                         "rests at the surface instead of slightly inside it; only full-space "
                         "objects use it: reduced ones keep their skin off the surface instead "
                         "(docs/method.md, \"Compliance\", \"Preload in full space only\")"),
            enum_key(S::solver, "contact_normals", &SolverSettings::contact_normals,
                { "auto", "iterate", "step" })
                .set_default("auto")
                .set_doc("a contact of a vertex against a face of a moving object takes the "
                         "face's normal at each iteration's positions (iterate) or holds the "
                         "step start's (step); auto: full-space objects hold theirs, reduced "
                         "ones take the iterate's; a full-space or semi-reduced object's self "
                         "contacts hold theirs either way (docs/method.md, \"Planes that follow "
                         "the iterate\", \"Full space holds its planes\", \"Self contacts "
                         "hold their planes\")"),
            enum_key(S::solver, "detect_in_step", &SolverSettings::detect_in_step,
                { "auto", "on", "off" })
                .set_default("auto")
                .set_doc("the contacts are found again at the iterate halfway through each "
                         "step's iterations, besides at its start, so that a vertex pushed "
                         "against another surface during the step gets a contact (those of the "
                         "start that are not found again stay); auto: on in full space, off "
                         "otherwise; never in steps with hyper-reduced objects, which crushed "
                         "with it (docs/method.md, \"Contacts found again during the step\", "
                         "\"Full space holds its planes\")"),
            enum_key(
                S::solver, "contact_subspace", &SolverSettings::contact_subspace, { "on", "off" })
                .set_default("off")
                .set_doc("every 4 sweeps of a contact solve (with contacts between objects, "
                         "only in a step's last), the step to the forces that meet the pushing "
                         "contacts' conditions exactly, the others held: far fewer sweeps, but "
                         "it crushed 1 of 10 full-space runs of a sample (docs/method.md, "
                         "\"Subspace steps\")"),
            value_key(S::solver, "collision_margin", T::number, &SolverSettings::collision_margin)
                .set_default(0.01)
                .at_least(0)
                .set_doc("contact candidate distance between objects, fraction of the largest "
                         "bake's bounding-box diagonal"),
            value_key(S::solver, "contact_skin", T::number, &SolverSettings::contact_skin)
                .set_default(0.15)
                .at_least(0)
                .at_most(0.5)
                .set_doc("the gap a contact between objects keeps, fraction of the collision "
                         "margin: they rest that far apart instead of slightly inside each "
                         "other, where triangles stayed crossed; in every mode (docs/method.md, "
                         "\"Skin\", \"Full space holds its planes\")"),
            value_key(S::solver, "self_skin", T::number, &SolverSettings::self_skin)
                .set_default(0.5)
                .at_least(0)
                .at_most(0.9)
                .set_doc("the gap a self contact keeps, fraction of the collision margin, in "
                         "every mode: a body's parts rest that far apart instead of slightly "
                         "inside each other, where their triangles stayed crossed; never reached "
                         "at rest (docs/method.md, \"Self skin\", \"Self collision on by "
                         "default\")"),
            value_key(S::solver, "self_push_speed", T::number, &SolverSettings::self_push_speed)
                .set_default(0.02)
                .at_least(0)
                .set_doc("the fastest a self contact pushes a vertex that starts a step behind "
                         "its face back out, in the object's rest bounding-box diagonals per "
                         "second (0: it is only held where it starts; full-space objects push at "
                         "a quarter of it); pushed out at once, vertices pressed back in every "
                         "step pumped energy into piled bodies (docs/method.md, \"Self contacts "
                         "that start behind\", \"Self collision on by default\")"),
            value_key(S::solver, "compliance_cap", T::number, &SolverSettings::compliance_cap)
                .set_default(0.004)
                .at_least(0)
                .at_most(0.05)
                .set_doc("the deepest a contact between objects may sink by its compliance, "
                         "beyond the skin, fraction of the smaller object's bounding-box "
                         "diagonal (0: no cap); past it the contact is hard, in the last "
                         "contact solve of each step (docs/method.md, \"Compliance cap\")"),
            value_key(
                S::solver, "collision_friction", T::number, &SolverSettings::collision_friction)
                .set_default(0.3)
                .at_least(0)
                .set_doc("Coulomb friction coefficient between objects"),
            value_key(S::solver, "sleep_speed", T::number, &SolverSettings::sleep_speed)
                .set_default(0.01)
                .at_least(0)
                .set_doc("a dynamic object without moving pins sleeps (is not stepped, keeps its "
                         "place and collision bounds) once every node has been slower than this "
                         "many rest bounding-box diagonals per second for sleep_steps steps; it "
                         "wakes when a moving object's bounds meet its own or its pins move; 0 "
                         "turns sleeping off"),
            value_key(S::solver, "sleep_steps", T::integer, &SolverSettings::sleep_steps)
                .set_default(30)
                .at_least(1)
                .set_doc("consecutive slow steps before an object sleeps (see sleep_speed)"),
            value_key(S::solver, "hyper_samples", T::integer, &SolverSettings::hyper_samples)
                .set_default(0)
                .at_least(0)
                .set_doc("tets sampled by the hyper-reduced solver (--solver hyper), 0 for four "
                         "times as many as the model has reduced coordinates per axis, five times "
                         "where the objects collide (at least 256; docs/method.md, \"Hyper-reduced "
                         "contact\"); more is slower and closer to semi-reduced (equal with every "
                         "tet)"),
            value_key(S::solver, "reduced_pin_stiffness", T::number,
                &SolverSettings::reduced_pin_stiffness)
                .set_default(1.0)
                .above(0)
                .set_doc("pin weight of semi- and hyper-reduced bodies, relative to the largest "
                         "diagonal entry of the system matrix (full-space pins use 1e8): stiff "
                         "pins on a reduced body freeze every handle whose weights reach into "
                         "the pinned region; at 1 a stiff cantilever's error against full-space "
                         "PD is 1.8% RMS instead of 5.3% (16 handles)"),
            value_key(
                S::solver, "full_pin_stiffness", T::number, &SolverSettings::full_pin_stiffness)
                .set_default(1e8)
                .above(0)
                .set_doc("pin weight of full-space bodies (--solver full), relative to the "
                         "largest diagonal entry of the system matrix: stiff by default; set to "
                         "reduced_pin_stiffness to measure what soft pins alone cost")
        };
    }

    /// objects[]: each object and its material.
    std::vector<KeySpec> object_keys()
    {
        using S = Section;
        using T = Type;
        const Json zero = Json::array({ 0, 0, 0 });
        return { // objects[]
            value_key(S::object, "name", T::string, &ObjectSettings::name)
                .set_default_doc("object0, object1, ...")
                .set_check(check_not_empty)
                .set_doc("unique name; by default \"object\" and the index in objects"),
            enum_key(
                S::object, "motion", &ObjectSettings::motion, { "dynamic", "static", "kinematic" })
                .set_default("dynamic")
                .set_doc("dynamic: simulated; static: stays at its placement; kinematic: moves "
                         "rigidly as prescribed (keyframes, or else constant velocity and "
                         "angular_velocity); static and kinematic objects are not simulated and "
                         "serve as mesh colliders for the others"),
            value_key(S::object, "bake", T::path, &ObjectSettings::bake)
                .set_required()
                .set_doc("the bake file (mat-bake output), relative to the scene file's "
                         "directory"),
            value_key(S::object, "position", T::vec3, &ObjectSettings::position)
                .set_default(zero)
                .set_doc("translation applied after the rotation, m"),
            value_key(S::object, "rotation_degrees", T::vec3, &ObjectSettings::rotation_degrees)
                .set_default(zero)
                .set_doc("XYZ Euler angles, degrees: about x, then y, then z (fixed axes), "
                         "about the bake's origin"),
            value_key(S::object, "velocity", T::vec3, &ObjectSettings::velocity)
                .set_default(zero)
                .set_doc("initial velocity, m/s (a kinematic object without keyframes keeps it)"),
            value_key(S::object, "angular_velocity", T::vec3, &ObjectSettings::angular_velocity)
                .set_default(zero)
                .set_doc("initial angular velocity about the centre of mass, rad/s (a kinematic "
                         "object without keyframes keeps it)"),
            section_key(S::object, "material", S::material, &ObjectSettings::material)
                .set_doc("elastic material"),
            array_key(S::object, "pins", S::pin, &ObjectSettings::pins)
                .set_doc("pinned regions, in the bake's coordinates (before the object is "
                         "placed); not on a kinematic object"),
            array_key(S::object, "keyframes", S::object_keyframe, &ObjectSettings::keyframes)
                .set_doc("kinematic objects only: keyframes of the rigid motion; translation "
                         "and Euler angles are interpolated linearly, the first holds before it, "
                         "the last after it; not with velocity or angular_velocity"),

            // objects[].material
            value_key(S::material, "youngs_modulus", T::number, &MaterialSettings::youngs_modulus)
                .set_default(1e5)
                .above(0)
                .set_doc("Young's modulus E, Pa"),
            value_key(S::material, "poisson_ratio", T::number, &MaterialSettings::poisson_ratio)
                .set_default(0.3)
                .at_least(0)
                .below(0.5)
                .set_doc("Poisson's ratio"),
            value_key(S::material, "density", T::number, &MaterialSettings::density)
                .set_default(1000)
                .above(0)
                .set_doc("mass density, kg/m^3"),
            value_key(S::material, "strain_limits", T::interval, &MaterialSettings::strain_limits)
                .set_check(check_strain_limits)
                .set_doc("[min, max] bounds on the principal stretches, 0 <= min <= 1 <= max")
        };
    }

    /// objects[].pins[] and objects[].keyframes[]: pinned regions and prescribed motion.
    std::vector<KeySpec> motion_keys()
    {
        using S = Section;
        using T = Type;
        const Json zero = Json::array({ 0, 0, 0 });
        return { // objects[].pins[]: exactly one of box, sphere, nodes.
            section_key(S::pin, "box", S::box, &PinRegion::box)
                .set_default(nullptr)
                .set_doc("the nodes in a box; exactly one of box, sphere, nodes"),
            section_key(S::pin, "sphere", S::sphere, &PinRegion::sphere)
                .set_default(nullptr)
                .set_doc("the nodes in a ball; exactly one of box, sphere, nodes"),
            value_key(S::pin, "nodes", T::integers, &PinRegion::nodes)
                .at_least(0)
                .set_min_count(1)
                .set_doc("tet-mesh node indices; exactly one of box, sphere, nodes"),
            array_key(S::pin, "motion", S::keyframe, &PinRegion::motion)
                .set_doc("keyframes of a rigid motion; translation and Euler angles are "
                         "interpolated linearly, the first holds before it, the last after it"),

            // objects[].pins[].box
            value_key(S::box, "min", T::vec3, &PinBox::min)
                .set_required()
                .set_doc("lower corner, m"),
            value_key(S::box, "max", T::vec3, &PinBox::max)
                .set_required()
                .set_doc("upper corner, >= min componentwise, m"),

            // objects[].pins[].sphere
            value_key(S::sphere, "center", T::vec3, &PinSphere::center)
                .set_required()
                .set_doc("centre, m"),
            value_key(S::sphere, "radius", T::number, &PinSphere::radius)
                .set_required()
                .above(0)
                .set_doc("radius, m"),

            // objects[].pins[].motion[]
            value_key(S::keyframe, "time", T::number, &PinKeyframe::time)
                .set_required()
                .at_least(0)
                .set_doc("s, strictly increasing along the list"),
            value_key(S::keyframe, "translation", T::vec3, &PinKeyframe::translation)
                .set_default(zero)
                .set_doc("displacement of the region, m"),
            value_key(S::keyframe, "rotation_degrees", T::vec3, &PinKeyframe::rotation_degrees)
                .set_default(zero)
                .set_doc("XYZ Euler angles, degrees, about the region's rest centroid"),

            // objects[].keyframes[]
            value_key(S::object_keyframe, "time", T::number, &PinKeyframe::time)
                .set_required()
                .at_least(0)
                .set_doc("s, strictly increasing along the list"),
            value_key(S::object_keyframe, "translation", T::vec3, &PinKeyframe::translation)
                .set_default(zero)
                .set_doc("displacement from the placement, m"),
            value_key(
                S::object_keyframe, "rotation_degrees", T::vec3, &PinKeyframe::rotation_degrees)
                .set_default(zero)
                .set_doc("XYZ Euler angles, degrees, about the placed centre of mass")
        };
    }

    /// colliders[] and output.
    std::vector<KeySpec> output_keys()
    {
        using S = Section;
        using T = Type;
        const Json zero = Json::array({ 0, 0, 0 });
        return { // colliders[]
            enum_key(S::collider, "type", &ColliderSettings::type, { "plane" })
                .set_required()
                .set_doc("collider kind"),
            value_key(S::collider, "point", T::vec3, &ColliderSettings::point)
                .set_default(zero)
                .set_doc("a point on the plane, m"),
            value_key(S::collider, "normal", T::vec3, &ColliderSettings::normal)
                .set_default(Json::array({ 0, 1, 0 }))
                .set_check(check_nonzero)
                .set_doc("normal pointing to the free side, non-zero (normalized on reading)"),
            value_key(S::collider, "friction", T::number, &ColliderSettings::friction)
                .set_default(0.5)
                .at_least(0)
                .set_doc("Coulomb friction coefficient"),

            // output
            enum_list_key(
                S::output, "format", &OutputSettings::formats, { "obj", "ply", "vtu", "h5" })
                .set_default(Json::array({ "obj" }))
                .set_accept_single()
                .set_min_count(1)
                .set_doc("file formats, a string or a list (h5: one HDF5 trajectory cache)"),
            value_key(S::output, "every", T::integer, &OutputSettings::every)
                .set_default(1)
                .at_least(1)
                .set_doc("time steps per output frame; not with time.fps"),
            enum_list_key(S::output, "fields", &OutputSettings::fields, { "velocity", "stretch" })
                .set_default(Json::array())
                .set_doc("extra per-vertex fields written to vtu and h5")
        };
    }

    /// Every key of the scene file, section by section, in the reference's order.
    std::vector<KeySpec> make_table()
    {
        std::vector<KeySpec> table;
        for (std::vector<KeySpec> (*section)() :
            { root_keys, time_keys, solver_keys, object_keys, motion_keys, output_keys }) {
            std::vector<KeySpec> keys = section();
            table.insert(table.end(), std::make_move_iterator(keys.begin()),
                std::make_move_iterator(keys.end()));
        }
        return table;
    }

    std::string format_number(double value)
    {
        return fmt::format("{}", value);
    }

} // namespace

bool Limits::contains(double value) const
{
    if (lower && (lower_open ? !(value > *lower) : !(value >= *lower)))
        return false;
    if (upper && (upper_open ? !(value < *upper) : !(value <= *upper)))
        return false;
    return true;
}

std::string Limits::text() const
{
    if (lower && upper)
        return fmt::format("{}{}, {}{}", lower_open ? "(" : "[", format_number(*lower),
            format_number(*upper), upper_open ? ")" : "]");
    if (lower)
        return fmt::format("{} {}", lower_open ? ">" : ">=", format_number(*lower));
    if (upper)
        return fmt::format("{} {}", upper_open ? "<" : "<=", format_number(*upper));
    return "";
}

const std::vector<KeySpec>& key_table()
{
    static const std::vector<KeySpec> table = make_table();
    return table;
}

std::string section_path(Section section)
{
    if (section == Section::root)
        return "";
    for (const KeySpec& key : key_table()) {
        if ((key.type == Type::section || key.type == Type::section_array)
            && key.child == section) {
            const std::string parent = section_path(key.section);
            return (parent.empty() ? "" : parent + ".") + key.name
                + (key.type == Type::section_array ? "[]" : "");
        }
    }
    MAT_CHECK(false, "scene schema: a section has no key that opens it");
    return "";
}

std::string join_key(const std::string& path, const std::string& key)
{
    return path.empty() ? key : path + "." + key;
}

std::string element_path(const std::string& path, std::size_t index)
{
    return fmt::format("{}[{}]", path, index);
}

std::string short_json(const Json& value, std::size_t max_length)
{
    std::string text;
    switch (value.type()) {
    case Json::value_t::number_float:
        text = format_number(value.get<double>());
        break;
    case Json::value_t::number_integer:
        text = fmt::format("{}", value.get<std::int64_t>());
        break;
    case Json::value_t::number_unsigned:
        text = fmt::format("{}", value.get<std::uint64_t>());
        break;
    case Json::value_t::array:
        text = "[";
        for (std::size_t i = 0; i < value.size() && text.size() <= max_length; ++i)
            text += (i == 0 ? "" : ", ") + short_json(value[i], max_length);
        text += "]";
        break;
    default:
        // Strings (quoted, escaped), booleans, null, objects: nlohmann's compact form, with
        // non-ASCII bytes escaped so that the message stays printable.
        text = value.dump(-1, ' ', true, Json::error_handler_t::replace);
        break;
    }
    if (text.size() > max_length)
        text = text.substr(0, max_length) + "...";
    return text;
}

} // namespace mat::scene_schema
