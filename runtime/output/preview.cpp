#include "runtime/output/preview.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <fmt/format.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/atomic_file.hpp"
#include "formats/png_io.hpp"
#include "runtime/simulation.hpp"

extern char** environ;

namespace mat {

namespace {

    constexpr double pi = 3.14159265358979323846;

    /// Twice the signed area of the 2D triangle (a, b, c): the edge function of (a, b) at c.
    double edge(const Vec2& a, const Vec2& b, const Vec2& c)
    {
        return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    }

    /// A unit vector perpendicular to the unit vector `n`.
    Vec3 perpendicular(const Vec3& n)
    {
        const Vec3 axis = std::abs(n.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
        return (axis - axis.dot(n) * n).normalized();
    }

    /// Object colors (r, g, b in [0, 1]), cycled; static objects are grey.
    const std::array<Vec3, 8> palette { Vec3(0.27, 0.51, 0.80), Vec3(0.96, 0.55, 0.20),
        Vec3(0.36, 0.70, 0.36), Vec3(0.84, 0.29, 0.29), Vec3(0.60, 0.46, 0.78),
        Vec3(0.62, 0.45, 0.36), Vec3(0.90, 0.52, 0.76), Vec3(0.74, 0.74, 0.30) };
    const Vec3 static_color(0.62, 0.63, 0.66);
    const Vec3 background_color(0.93, 0.94, 0.96);

} // namespace

Vec3 PreviewCamera::project(const Vec3& p) const
{
    const Vec3 q = axes * (p - eye);
    return Vec3(0.5 * width + focal * q.x() / q.z(), 0.5 * height - focal * q.y() / q.z(), q.z());
}

PreviewCamera frame_bounds(
    const Vec3& lo, const Vec3& hi, const Vec3& up, int width, int height, double margin)
{
    MAT_CHECK(
        width > 0 && height > 0, "preview: image size {} x {} is not positive", width, height);
    const Vec3 u = up.norm() > 0.0 ? Vec3(up.normalized()) : Vec3(Vec3::UnitY());
    // The horizontal direction towards the viewer, turned 30 degrees about up; then 20 degrees up.
    const Vec3 front = perpendicular(u);
    const double yaw = 30.0 * pi / 180.0, pitch = 20.0 * pi / 180.0;
    const Vec3 side = std::cos(yaw) * front + std::sin(yaw) * u.cross(front);
    const Vec3 forward = -(std::cos(pitch) * side + std::sin(pitch) * u).normalized();
    const Vec3 right = forward.cross(u).normalized();
    PreviewCamera camera;
    camera.width = width;
    camera.height = height;
    camera.axes.row(0) = right;
    camera.axes.row(1) = right.cross(forward);
    camera.axes.row(2) = forward;
    camera.focal = 0.5 * height / std::tan(20.0 * pi / 180.0);
    // Distance d from the centre along -forward: a corner at camera offsets (x, y, z) from the
    // centre projects inside if focal |x| / (z + d) <= (1 - margin) width / 2, likewise for y.
    const Vec3 centre = 0.5 * (lo + hi);
    const double diagonal = (hi - lo).norm();
    const double half_x = (1.0 - margin) * 0.5 * width, half_y = (1.0 - margin) * 0.5 * height;
    double distance = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
        const Vec3 p((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
            (corner & 4) ? hi.z() : lo.z());
        const Vec3 q = camera.axes * (p - centre);
        distance = std::max(distance, camera.focal * std::abs(q.x()) / half_x - q.z());
        distance = std::max(distance, camera.focal * std::abs(q.y()) / half_y - q.z());
        distance = std::max(distance, -q.z() + 0.05 * diagonal);
    }
    distance = std::max(distance, 1e-3 * std::max(diagonal, 1.0));
    camera.eye = centre - distance * forward;
    return camera;
}

PreviewImage::PreviewImage(int width, int height)
    : m_width(width)
    , m_height(height)
{
    MAT_CHECK(
        width > 0 && height > 0, "preview: image size {} x {} is not positive", width, height);
    m_inverse_depth.assign(
        static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0.0f);
    m_rgb.assign(3 * m_inverse_depth.size(), 0);
}

Eigen::Vector3i PreviewImage::pixel(int x, int y) const
{
    const std::size_t i = 3 * index(x, y);
    return Eigen::Vector3i(m_rgb[i], m_rgb[i + 1], m_rgb[i + 2]);
}

void PreviewImage::put(int x, int y, const Vec3& color)
{
    const std::size_t i = 3 * index(x, y);
    for (int c = 0; c < 3; ++c)
        m_rgb[i + c] = static_cast<std::uint8_t>(255.0 * std::clamp(color(c), 0.0, 1.0) + 0.5);
}

void PreviewImage::clear(const Vec3& background)
{
    std::fill(m_inverse_depth.begin(), m_inverse_depth.end(), 0.0f);
    put(0, 0, background);
    for (std::size_t i = 3; i < m_rgb.size(); ++i)
        m_rgb[i] = m_rgb[i - 3];
}

void PreviewImage::draw_mesh(const PreviewCamera& camera, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3i>& faces, const Vec3& color)
{
    // Towards the light, fixed to the camera: from above, left and behind the viewer.
    const Vec3 light = camera.axes.transpose() * Vec3(-0.4, 0.7, -1.0).normalized();
    const double near = 1e-9 * std::max(1.0, camera.eye.norm());
    for (Index f = 0; f < faces.rows(); ++f) {
        std::array<Vec3, 3> world, screen;
        for (int k = 0; k < 3; ++k) {
            const int v = faces(f, k);
            MAT_CHECK(v >= 0 && v < positions.rows(), "preview: face {} names vertex {} of {}", f,
                v, positions.rows());
            world[k] = positions.row(v).transpose();
            screen[k] = camera.project(world[k]);
        }
        if (!(screen[0].z() > near && screen[1].z() > near && screen[2].z() > near))
            continue; // behind the camera (or not finite)
        const Vec2 a = screen[0].head<2>(), b = screen[1].head<2>(), c = screen[2].head<2>();
        const double area = edge(a, b, c);
        if (!(std::abs(area) > 1e-12) || !std::isfinite(area))
            continue; // degenerate, or not finite
        // Flat shading: ambient plus Lambert on the face normal, both sides lit.
        const Vec3 normal = (world[1] - world[0]).cross(world[2] - world[0]);
        const double lambert = normal.norm() > 0.0 ? std::abs(normal.normalized().dot(light)) : 0.0;
        const Vec3 shaded = (0.3 + 0.7 * lambert) * color;
        const std::array<double, 3> inverse_depth { 1.0 / screen[0].z(), 1.0 / screen[1].z(),
            1.0 / screen[2].z() };
        const double x_min = std::min({ a.x(), b.x(), c.x() }),
                     x_max = std::max({ a.x(), b.x(), c.x() });
        const double y_min = std::min({ a.y(), b.y(), c.y() }),
                     y_max = std::max({ a.y(), b.y(), c.y() });
        if (x_max < 0.0 || y_max < 0.0 || x_min > m_width || y_min > m_height)
            continue;
        // Clamped in double first: a huge (but finite) coordinate must not overflow an int.
        const int x0 = static_cast<int>(std::max(0.0, std::floor(x_min)));
        const int x1 = static_cast<int>(std::min(m_width - 1.0, std::ceil(x_max)));
        const int y0 = static_cast<int>(std::max(0.0, std::floor(y_min)));
        const int y1 = static_cast<int>(std::min(m_height - 1.0, std::ceil(y_max)));
        for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) {
                // Pixel centres inside the triangle (both windings); 1 / depth is affine in the
                // image plane, so its barycentric interpolation is exact.
                const Vec2 p(x + 0.5, y + 0.5);
                const double w0 = edge(b, c, p) / area, w1 = edge(c, a, p) / area,
                             w2 = edge(a, b, p) / area;
                if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0)
                    continue;
                const float depth = static_cast<float>(
                    w0 * inverse_depth[0] + w1 * inverse_depth[1] + w2 * inverse_depth[2]);
                float& stored = m_inverse_depth[index(x, y)];
                if (depth > stored) {
                    stored = depth;
                    put(x, y, shaded);
                }
            }
        }
    }
}

void PreviewImage::draw_plane(const PreviewCamera& camera, const Vec3& point, const Vec3& normal,
    double cell, const Vec3& centre, double extent, const Vec3& background)
{
    const Vec3 n = normal.normalized();
    const double height = n.dot(camera.eye - point);
    if (!(height > 0.0) || !(cell > 0.0) || !(extent > 0.0))
        return;
    const Vec3 t1 = perpendicular(n), t2 = n.cross(t1);
    const Vec3 light = Vec3(0.82, 0.83, 0.85), dark = Vec3(0.70, 0.71, 0.74);
    for (int y = 0; y < m_height; ++y) {
        for (int x = 0; x < m_width; ++x) {
            // The ray through the pixel centre, with unit speed along the view direction.
            const Vec3 ray = camera.axes.transpose()
                * Vec3((x + 0.5 - 0.5 * m_width) / camera.focal,
                    -(y + 0.5 - 0.5 * m_height) / camera.focal, 1.0);
            const double along = n.dot(ray);
            if (!(along < 0.0))
                continue;
            const double depth = height / -along;
            const Vec3 hit = camera.eye + depth * ray;
            const double fade = (hit - centre).norm() / extent;
            if (fade >= 1.0)
                continue;
            const float inverse = static_cast<float>(1.0 / depth);
            float& stored = m_inverse_depth[index(x, y)];
            if (inverse <= stored)
                continue;
            stored = inverse;
            const Vec3 local = hit - point;
            const long i = std::lround(std::floor(local.dot(t1) / cell))
                + std::lround(std::floor(local.dot(t2) / cell));
            const Vec3 checker = (i % 2 == 0) ? light : dark;
            put(x, y, checker + fade * fade * (background - checker));
        }
    }
}

PreviewWriter::PreviewWriter(
    const Simulation& simulation, std::string directory, int width, int height)
    : m_directory(std::move(directory))
    , m_image(width, height)
{
    const auto& bodies = simulation.bodies();
    Box3 bounds;
    int moving = 0;
    for (const Body& body : bodies) {
        m_surface.emplace_back(body.model->surface().num_vertices(), 3);
        body.model->surface().positions(body.state.positions, m_surface.back());
        for (Index v = 0; v < m_surface.back().rows(); ++v)
            bounds.extend(m_surface.back().row(v).transpose());
        m_colors.push_back(body.is_static ? static_color : palette[moving++ % palette.size()]);
    }
    if (bounds.isEmpty())
        bounds.extend(Vec3::Zero());
    const Scene& scene = simulation.scene();
    Vec3 up = -scene.gravity;
    if (!(up.norm() > 0.0))
        up = scene.colliders.empty() ? Vec3(Vec3::UnitY()) : scene.colliders.front().normal;
    m_centre = bounds.center();
    m_diagonal = std::max(bounds.diagonal().norm(), 1e-6);
    // A ground plane not far below the objects is in the picture too (where they will land): the
    // framed box takes in the bounds' shadow on it.
    const Box3 objects = bounds;
    for (const ColliderSettings& collider : scene.colliders) {
        const Vec3 n = collider.normal.normalized();
        const double height = n.dot(m_centre - collider.point);
        if (collider.type != ColliderType::plane || !(height > 0.0) || height > 2.0 * m_diagonal)
            continue;
        for (int corner = 0; corner < 8; ++corner) {
            const Vec3 p = objects.corner(static_cast<Box3::CornerType>(corner));
            bounds.extend(p - n.dot(p - collider.point) * n);
        }
    }
    m_camera = frame_bounds(bounds.min(), bounds.max(), up, width, height);
    const std::string frames = m_directory + "/preview";
    std::error_code error;
    std::filesystem::create_directories(frames, error);
    if (error || !std::filesystem::is_directory(frames))
        throw_error("{}: cannot create the preview directory ({})", frames,
            error ? error.message() : "not a directory");
}

void PreviewWriter::write_frame(int frame, const Simulation& simulation)
{
    m_image.clear(background_color);
    for (const ColliderSettings& collider : simulation.scene().colliders) {
        if (collider.type != ColliderType::plane)
            continue;
        const Vec3 n = collider.normal.normalized();
        const Vec3 foot = m_centre - n.dot(m_centre - collider.point) * n;
        m_image.draw_plane(m_camera, collider.point, n, 0.125 * m_diagonal, foot, 2.5 * m_diagonal,
            background_color);
    }
    const auto& bodies = simulation.bodies();
    MAT_CHECK(bodies.size() == m_surface.size(), "preview: {} bodies, framed {}", bodies.size(),
        m_surface.size());
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        bodies[b].model->surface().positions(bodies[b].state.positions, m_surface[b]);
        m_image.draw_mesh(m_camera, m_surface[b], bodies[b].model->surface().faces(), m_colors[b]);
    }
    write_png(fmt::format("{}/preview/frame_{:05d}.png", m_directory, frame), m_image.width(),
        m_image.height(), m_image.rgb());
    ++m_files;
}

bool PreviewWriter::write_movie(double fps) const
{
    if (m_files == 0 || !(fps > 0.0))
        return false;
    const std::string target = m_directory + "/preview.mp4";
    try {
        AtomicFile file(target);
        const std::string rate = fmt::format("{:.6g}", fps);
        const std::string pattern = m_directory + "/preview/frame_%05d.png";
        // Even sizes for yuv420p; -f mp4 since the temporary name has another extension.
        std::vector<std::string> args { "ffmpeg", "-nostdin", "-y", "-loglevel", "error",
            "-framerate", rate, "-i", pattern, "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt",
            "yuv420p", "-f", "mp4", file.temp_path() };
        std::vector<char*> argv;
        for (std::string& arg : args)
            argv.push_back(arg.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
        posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
        pid_t pid = 0;
        const int spawned = posix_spawnp(&pid, "ffmpeg", &actions, nullptr, argv.data(), environ);
        posix_spawn_file_actions_destroy(&actions);
        if (spawned == ENOENT) {
            logger().info("preview: ffmpeg is not on PATH, no {}", target);
            return false;
        }
        if (spawned != 0) {
            logger().warn("preview: cannot run ffmpeg ({}), no {}", std::strerror(spawned), target);
            return false;
        }
        int status = 0;
        while (waitpid(pid, &status, 0) < 0 && errno == EINTR) { }
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
            logger().warn("preview: ffmpeg failed (status {}), no {}", status, target);
            return false;
        }
        file.commit();
    } catch (const Error& e) {
        logger().warn("preview: {}", e.what());
        return false;
    }
    logger().info("preview: wrote {}", target);
    return true;
}

} // namespace mat
