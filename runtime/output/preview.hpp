#pragma once
// Headless preview pictures of a run (mat-run --preview): a small z-buffer rasterizer with flat
// shading, a fixed camera framing the scene's initial bounds, one color per object and the
// scene's ground planes as a checkerboard; PNG frames (formats/png_io.hpp) and, where ffmpeg is
// on PATH, an MP4 of them.

#include <cstdint>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

class Simulation;

/// A pinhole camera. Pixel coordinates: x to the right, y down, pixel (i, j) covers
/// [i, i + 1) x [j, j + 1); depth is the distance along the view direction.
struct PreviewCamera {
    Vec3 eye = Vec3::Zero();
    Mat3 axes = Mat3::Identity(); ///< rows: right, up, forward (unit vectors, world frame)
    double focal = 1.0; ///< focal length in pixels
    int width = 640;
    int height = 480;

    /// (pixel x, pixel y, depth) of the world point `p`.
    Vec3 project(const Vec3& p) const;
};

/// The camera that looks at the box [lo, hi] from the front, 30 degrees to the side and 20
/// degrees from above (`up` is the world's up direction), with a 40 degree vertical field of
/// view, as close as it can be while every corner of the box projects inside the image with a
/// `margin` (fraction of the half-size) to spare.
PreviewCamera frame_bounds(
    const Vec3& lo, const Vec3& hi, const Vec3& up, int width, int height, double margin = 0.1);

/// An RGB image with a depth buffer.
class PreviewImage {
public:
    PreviewImage(int width, int height);

    int width() const { return m_width; }
    int height() const { return m_height; }
    /// width * height * 3 bytes, rows top to bottom.
    const std::vector<std::uint8_t>& rgb() const { return m_rgb; }
    /// The color of pixel (x, y), components 0..255.
    Eigen::Vector3i pixel(int x, int y) const;
    /// True once something was drawn at pixel (x, y).
    bool covered(int x, int y) const { return m_inverse_depth[index(x, y)] > 0.0f; }

    /// Fills the image with `background` (r, g, b in [0, 1]) and empties the depth buffer.
    void clear(const Vec3& background);
    /// Draws the triangles `faces`  #F x 3 of `positions`  #V x 3 (world frame) in `color`
    /// (r, g, b in [0, 1]), flat shaded (Lambert, both sides lit) by a light fixed to the camera
    /// (above, left and behind it). Triangles reaching behind the camera are skipped.
    void draw_mesh(const PreviewCamera& camera, const Eigen::Ref<const MatX3>& positions,
        const Eigen::Ref<const MatX3i>& faces, const Vec3& color);
    /// Draws the plane through `point` with normal `normal` as a grey checkerboard of squares of
    /// side `cell`, fading into `background` at the distance `extent` from `centre`. Nothing is
    /// drawn when the camera is below the plane.
    void draw_plane(const PreviewCamera& camera, const Vec3& point, const Vec3& normal, double cell,
        const Vec3& centre, double extent, const Vec3& background);

private:
    std::size_t index(int x, int y) const
    {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(m_width)
            + static_cast<std::size_t>(x);
    }
    void put(int x, int y, const Vec3& color);

    int m_width, m_height;
    std::vector<float> m_inverse_depth; ///< 1 / depth, 0 = empty
    std::vector<std::uint8_t> m_rgb;
};

/// Writes the preview frames of a simulation: DIR/preview/frame_fffff.png.
class PreviewWriter {
public:
    /// Frames the bodies' surfaces as they are now (call it before the first step) and creates
    /// DIR/preview. Throws mat::Error if the size is not positive or the directory cannot be made.
    PreviewWriter(const Simulation& simulation, std::string directory, int width, int height);

    /// Renders the bodies' current surfaces and writes frame `frame`.
    void write_frame(int frame, const Simulation& simulation);
    /// If ffmpeg is on PATH, assembles the frames into DIR/preview.mp4 at `fps` frames per
    /// second and returns true; failures are logged as warnings, never thrown.
    bool write_movie(double fps) const;
    long files_written() const { return m_files; }

private:
    std::string m_directory;
    PreviewCamera m_camera;
    PreviewImage m_image;
    std::vector<Vec3> m_colors; ///< per body
    double m_diagonal = 1.0; ///< of the initial bounds
    Vec3 m_centre = Vec3::Zero(); ///< of the initial bounds
    std::vector<MatX3> m_surface; ///< per body  #Vs x 3, workspace
    long m_files = 0;
};

} // namespace mat
