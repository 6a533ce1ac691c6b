// Speed against accuracy charts (docs/make_charts.sh):
//   speed_accuracy_chart RESULTS.csv OUT_DIR TABLE.md [--note TEXT] [--link-dir DIR]
// RESULTS.csv has the header scene,method,parameter,value,ms_per_step,rms_percent,max_percent
// (no quoted fields: labels hold no commas). For every scene, in the order of the file, writes
// OUT_DIR/SCENE.svg: two log-log panels (RMS and max surface distance to the reference, % of the
// bounding-box diagonal, against milliseconds per step), one polyline with markers per method
// (points in the file's order, each labelled with its value), decade ticks, a legend; errors more
// than 4 decades below the largest are left off the chart (counted in a note). TABLE.md
// gets a Markdown section per scene: the chart and a table of every point. Every file is written
// atomically; a malformed line is an error naming the file and the line. Each scene's section
// opens with its time-to-accuracy table: for RMS targets 5%, 2%, 1% and 0.5%, the fastest point
// of each method that reaches it (ms per step and setting), and the fastest method (CPU and GPU
// series apart: a method named "... on the GPU" was timed on a GPU machine).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/error.hpp"
#include "formats/text_io.hpp"

namespace mat {
namespace {

    struct Point {
        std::string value; ///< the series parameter's value (iterations, handles)
        double ms = 0.0; ///< ms per step
        double rms = 0.0; ///< %
        double max = 0.0; ///< %
    };

    struct Series {
        std::string method;
        std::string parameter; ///< "iterations", "handles"
        std::vector<Point> points;
    };

    struct SceneResults {
        std::string name;
        std::vector<Series> series;
    };

    /// A series whose method ends with " on the GPU" was timed on a GPU machine
    /// (docs/make_charts.sh, GPU_METHODS): the fronts and the fastest row keep it apart from
    /// the CPU runs, whose times come from another machine.
    bool on_gpu(const Series& series)
    {
        const std::string suffix = " on the GPU";
        const std::string& m = series.method;
        return m.size() >= suffix.size()
            && m.compare(m.size() - suffix.size(), suffix.size(), suffix) == 0;
    }

    bool has_gpu_series(const SceneResults& scene)
    {
        return std::any_of(scene.series.begin(), scene.series.end(), on_gpu);
    }

    std::vector<std::string> split(const std::string& line)
    {
        std::vector<std::string> fields;
        std::stringstream in(line);
        std::string field;
        while (std::getline(in, field, ','))
            fields.push_back(field);
        if (!line.empty() && line.back() == ',')
            fields.emplace_back();
        return fields;
    }

    double parse_number(const std::string& text, const std::string& file, int line, int column)
    {
        try {
            std::size_t used = 0;
            const double value = std::stod(text, &used);
            if (used == text.size() && std::isfinite(value) && value >= 0.0)
                return value;
        } catch (const std::exception&) {
        }
        throw_error(
            "{}: line {}: field {} '{}' is not a finite number >= 0", file, line, column + 1, text);
    }

    std::vector<SceneResults> read_results(const std::string& file)
    {
        std::ifstream in(file);
        if (!in)
            throw_error("{}: cannot open", file);
        const std::string header = "scene,method,parameter,value,ms_per_step,rms_percent,"
                                   "max_percent";
        std::string line;
        if (!std::getline(in, line) || line != header)
            throw_error("{}: line 1: expected the header '{}'", file, header);
        std::vector<SceneResults> scenes;
        for (int number = 2; std::getline(in, line); ++number) {
            if (line.empty())
                continue;
            const std::vector<std::string> f = split(line);
            if (f.size() != 7)
                throw_error("{}: line {}: {} fields, expected 7", file, number, f.size());
            for (int c = 0; c < 4; ++c)
                if (f[std::size_t(c)].empty())
                    throw_error("{}: line {}: field {} is empty", file, number, c + 1);
            auto scene = std::find_if(scenes.begin(), scenes.end(),
                [&](const SceneResults& s) { return s.name == f[0]; });
            if (scene == scenes.end())
                scene = scenes.insert(scenes.end(), SceneResults { f[0], {} });
            auto series = std::find_if(scene->series.begin(), scene->series.end(),
                [&](const Series& s) { return s.method == f[1]; });
            if (series == scene->series.end())
                series = scene->series.insert(scene->series.end(), Series { f[1], f[2], {} });
            series->points.push_back(Point { f[3], parse_number(f[4], file, number, 4),
                parse_number(f[5], file, number, 5), parse_number(f[6], file, number, 6) });
        }
        if (scenes.empty())
            throw_error("{}: no results", file);
        return scenes;
    }

    std::string xml_escape(const std::string& text)
    {
        std::string out;
        for (char c : text) {
            if (c == '&')
                out += "&amp;";
            else if (c == '<')
                out += "&lt;";
            else if (c == '>')
                out += "&gt;";
            else if (c == '"')
                out += "&quot;";
            else
                out += c;
        }
        return out;
    }

    /// A log10 axis over whole decades [10^lo, 10^hi] mapped onto pixels [from, to].
    struct LogAxis {
        int lo = 0, hi = 1;
        double from = 0.0, to = 1.0;

        static LogAxis covering(double smallest, double largest, double from, double to)
        {
            LogAxis axis;
            axis.lo = int(std::floor(std::log10(smallest) + 1e-9));
            axis.hi = std::max(axis.lo + 1, int(std::ceil(std::log10(largest) - 1e-9)));
            axis.from = from;
            axis.to = to;
            return axis;
        }
        double operator()(double value) const
        {
            const double t = (std::log10(value) - lo) / double(hi - lo);
            return from + t * (to - from);
        }
    };

    /// "0.01", "1", "100": the decade 10^k written plainly.
    std::string decade_label(int k)
    {
        if (k >= 0)
            return fmt::format("{:.0f}", std::pow(10.0, k));
        return fmt::format("{:.{}f}", std::pow(10.0, k), -k);
    }

    const char* const colors[] = { "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
        "#e377c2", "#17becf" };

    /// Series s's marker kind: the colours repeat every 8 series, the kinds every 4, so series 8
    /// to 31 shift the kind to stay distinct from those with their colour.
    int marker_kind(std::size_t s)
    {
        return int(s + s / std::size(colors));
    }

    /// The scene's points whose `which` error (0: RMS, 1: max) no other point beats at the same
    /// or less time: the Pareto front of error against ms per step, by increasing time (and so
    /// decreasing error), among the CPU series or (`gpu`) the GPU series. Points without a
    /// positive time and error are not on it.
    std::vector<const Point*> pareto_front(const SceneResults& scene, int which, bool gpu = false)
    {
        const auto error = [which](const Point* p) { return which == 0 ? p->rms : p->max; };
        std::vector<const Point*> points;
        for (const Series& series : scene.series)
            for (const Point& p : series.points)
                if (on_gpu(series) == gpu && p.ms > 0.0 && error(&p) > 0.0)
                    points.push_back(&p);
        std::stable_sort(points.begin(), points.end(), [&](const Point* a, const Point* b) {
            return a->ms < b->ms || (a->ms == b->ms && error(a) < error(b));
        });
        std::vector<const Point*> front;
        for (const Point* p : points)
            if (front.empty() || error(p) < error(front.back()))
                front.push_back(p);
        return front;
    }

    /// An SVG marker of kind `kind` (circle, square, triangle, diamond, ...) centred at x, y.
    std::string marker(int kind, double x, double y, const char* color)
    {
        const double r = 4.0;
        switch (kind % 4) {
        case 0:
            return fmt::format(
                "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{}\" fill=\"{}\"/>\n", x, y, r, color);
        case 1:
            return fmt::format(
                "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{}\" height=\"{}\" fill=\"{}\"/>\n", x - r,
                y - r, 2 * r, 2 * r, color);
        case 2:
            return fmt::format("<path d=\"M{:.1f},{:.1f} L{:.1f},{:.1f} L{:.1f},{:.1f} Z\" "
                               "fill=\"{}\"/>\n",
                x, y - 1.2 * r, x + 1.1 * r, y + 0.8 * r, x - 1.1 * r, y + 0.8 * r, color);
        default:
            return fmt::format("<path d=\"M{:.1f},{:.1f} L{:.1f},{:.1f} L{:.1f},{:.1f} "
                               "L{:.1f},{:.1f} Z\" fill=\"{}\"/>\n",
                x, y - 1.3 * r, x + 1.3 * r, y, x, y + 1.3 * r, x - 1.3 * r, y, color);
        }
    }

    /// One panel: frame, decade ticks and grid, axis titles, and every series' `which` error
    /// (0: RMS, 1: max).
    std::string panel(const SceneResults& scene, const LogAxis& x, const LogAxis& y, int which,
        const std::string& title)
    {
        std::string svg;
        const double left = x.from, right = x.to, bottom = y.from, top = y.to;
        svg += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" "
                           "fill=\"white\" stroke=\"#444\"/>\n",
            left, top, right - left, bottom - top);
        // Grid: decades (labelled) and 2..9 within each decade (light).
        for (int k = x.lo; k <= x.hi; ++k)
            for (int m = 1; m <= 9 && (m == 1 || k < x.hi); ++m) {
                const double px = x(m * std::pow(10.0, k));
                svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" "
                                   "y2=\"{2:.1f}\" stroke=\"{3}\"/>\n",
                    px, top, bottom, m == 1 ? "#bbb" : "#eee");
                if (m == 1)
                    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">"
                                       "{}</text>\n",
                        px, bottom + 16, decade_label(k));
            }
        for (int k = y.lo; k <= y.hi; ++k)
            for (int m = 1; m <= 9 && (m == 1 || k < y.hi); ++m) {
                const double py = y(m * std::pow(10.0, k));
                svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{2:.1f}\" x2=\"{1:.1f}\" "
                                   "y2=\"{2:.1f}\" stroke=\"{3}\"/>\n",
                    left, right, py, m == 1 ? "#bbb" : "#eee");
                if (m == 1)
                    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\">"
                                       "{}</text>\n",
                        left - 6, py + 4, decade_label(k));
            }
        svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" "
                           "font-weight=\"bold\">{}</text>\n",
            0.5 * (left + right), top - 8, xml_escape(title));
        svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">time per step "
                           "(ms)</text>\n",
            0.5 * (left + right), bottom + 36);
        svg += fmt::format("<text transform=\"translate({:.1f},{:.1f}) rotate(-90)\" "
                           "text-anchor=\"middle\">error (% of the bounding-box diagonal)"
                           "</text>\n",
            left - 48, 0.5 * (top + bottom));
        // The Pareto front under the series: a wide band stepping down from each of its points
        // to the next (the least error reached within a time), on to the right edge.
        {
            const std::vector<const Point*> front = pareto_front(scene, which);
            std::string path;
            double last_y = 0.0;
            for (const Point* p : front) {
                const double px = x(p->ms);
                const double py = std::min(y(which == 0 ? p->rms : p->max), bottom);
                path += path.empty() ? fmt::format("M{:.1f},{:.1f}", px, py)
                                     : fmt::format(" H{:.1f} V{:.1f}", px, py);
                last_y = py;
            }
            if (!path.empty())
                svg += fmt::format("<path class=\"pareto\" d=\"{} H{:.1f}\" fill=\"none\" "
                                   "stroke=\"#f5c04a\" stroke-opacity=\"0.55\" stroke-width=\"9\" "
                                   "stroke-linejoin=\"round\"/>\n",
                    path, right, last_y);
        }
        // Series: a polyline through the points in order, a marker and the value at each.
        int hidden = 0;
        for (std::size_t s = 0; s < scene.series.size(); ++s) {
            const Series& series = scene.series[s];
            const char* color = colors[s % std::size(colors)];
            std::string path;
            std::string marks;
            for (const Point& p : series.points) {
                const double error = which == 0 ? p.rms : p.max;
                if (!(p.ms > 0.0) || !(error >= std::pow(10.0, y.lo) * (1.0 - 1e-9))) {
                    ++hidden; // below the chart (or an exact match of the reference)
                    continue;
                }
                const double px = x(p.ms), py = y(error);
                path += fmt::format("{}{:.1f},{:.1f}", path.empty() ? "M" : " L", px, py);
                marks += marker(marker_kind(s), px, py, color);
                marks += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"10\" "
                                     "fill=\"{}\">{}</text>\n",
                    px + 5, py - 5, color, xml_escape(p.value));
            }
            if (!path.empty())
                svg += fmt::format("<path d=\"{}\" fill=\"none\" stroke=\"{}\" "
                                   "stroke-width=\"1.5\"{}/>\n",
                    path, color, which == 1 ? " stroke-dasharray=\"6,3\"" : "");
            svg += marks;
        }
        if (hidden > 0)
            svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\" "
                               "font-size=\"10\" fill=\"#555\">{} point{} below {}% not "
                               "drawn (see the table)</text>\n",
                right - 4, bottom - 6, hidden, hidden == 1 ? "" : "s", decade_label(y.lo));
        return svg;
    }

    /// `text` broken at spaces into lines of at most `width` characters (a longer word gets a
    /// line of its own); no lines for empty text.
    std::vector<std::string> wrap_words(const std::string& text, std::size_t width)
    {
        std::vector<std::string> lines;
        std::string line;
        std::size_t at = 0;
        while (at < text.size()) {
            const std::size_t space = std::min(text.find(' ', at), text.size());
            const std::string word = text.substr(at, space - at);
            at = space + 1;
            if (word.empty())
                continue;
            if (!line.empty() && line.size() + 1 + word.size() > width) {
                lines.push_back(line);
                line.clear();
            }
            line += (line.empty() ? "" : " ") + word;
        }
        if (!line.empty())
            lines.push_back(line);
        return lines;
    }

    std::string scene_svg(const SceneResults& scene, const std::string& note)
    {
        double x_min = HUGE_VAL, x_max = 0.0, y_min = HUGE_VAL, y_max = 0.0;
        for (const Series& series : scene.series)
            for (const Point& p : series.points) {
                if (p.ms > 0.0) {
                    x_min = std::min(x_min, p.ms);
                    x_max = std::max(x_max, p.ms);
                }
                for (double e : { p.rms, p.max })
                    if (e > 0.0 && p.ms > 0.0) {
                        y_min = std::min(y_min, e);
                        y_max = std::max(y_max, e);
                    }
            }
        if (!(x_max > 0.0) || !(y_max > 0.0))
            throw_error("scene {}: no point with a positive time and error to plot", scene.name);
        // At most `decades` decades of error: a converged point far below the others would
        // squash them; such points are left out with a note.
        const double decades = 4.0;
        y_min = std::max(y_min, y_max * std::pow(10.0, -decades));
        const double panel_width = 400, panel_height = 320, margin_left = 80, gap = 90;
        const std::vector<std::string> note_lines = wrap_words(note, 150);
        // each note line past the first pushes the panels down by a line, plus a gap
        const double note_extra
            = note_lines.size() > 1 ? 14.0 * double(note_lines.size() - 1) + 8.0 : 0.0;
        const double top = 60 + note_extra, legend_top = top + panel_height + 60;
        const double legend_height = 20.0 * double(scene.series.size() + 1) + 10;
        const double width = margin_left + 2 * panel_width + gap + 30;
        const double height = legend_top + legend_height + 10;
        const LogAxis y = LogAxis::covering(y_min, y_max, top + panel_height, top);
        std::string svg = fmt::format("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                                      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0:.0f}\" "
                                      "height=\"{1:.0f}\" viewBox=\"0 0 {0:.0f} {1:.0f}\" "
                                      "font-family=\"sans-serif\" font-size=\"12\">\n"
                                      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
            width, height);
        svg += fmt::format("<text x=\"{:.1f}\" y=\"22\" text-anchor=\"middle\" font-size=\"15\" "
                           "font-weight=\"bold\">{}: error against time per step</text>\n",
            0.5 * width, xml_escape(scene.name));
        for (std::size_t i = 0; i < note_lines.size(); ++i)
            svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.0f}\" text-anchor=\"middle\" "
                               "font-size=\"11\" fill=\"#555\">{}</text>\n",
                0.5 * width, 38.0 + 14.0 * double(i), xml_escape(note_lines[i]));
        for (int which = 0; which < 2; ++which) {
            const double left = margin_left + which * (panel_width + gap);
            const LogAxis x = LogAxis::covering(x_min, x_max, left, left + panel_width);
            svg += panel(scene, x, y, which,
                which == 0 ? "RMS surface distance (solid)" : "max surface distance (dashed)");
        }
        for (std::size_t s = 0; s < scene.series.size(); ++s) {
            const char* color = colors[s % std::size(colors)];
            const double ly = legend_top + 20.0 * double(s) + 10;
            svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" "
                               "stroke=\"{}\" stroke-width=\"1.5\"/>\n",
                margin_left, ly, margin_left + 30, ly, color);
            svg += marker(marker_kind(s), margin_left + 15, ly, color);
            svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\">{} (labels: {})</text>\n",
                margin_left + 40, ly + 4, xml_escape(scene.series[s].method),
                xml_escape(scene.series[s].parameter));
        }
        const double front_y = legend_top + 20.0 * double(scene.series.size()) + 10;
        svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" "
                           "stroke=\"#f5c04a\" stroke-opacity=\"0.55\" stroke-width=\"9\"/>\n"
                           "<text x=\"{:.1f}\" y=\"{:.1f}\">Pareto front{}: the least error "
                           "reached within each time per step (no setting is both faster and "
                           "more accurate than its corners)</text>\n",
            margin_left, front_y, margin_left + 30, front_y, margin_left + 40, front_y + 4,
            has_gpu_series(scene) ? " of the CPU runs" : "");
        svg += "</svg>\n";
        return svg;
    }

    /// Milliseconds as the tables write them: 3 significant digits, whole numbers from 1000 on
    /// ("1466", not "1.47e+03").
    std::string ms_text(double ms)
    {
        return ms >= 1000.0 ? fmt::format("{:.0f}", ms) : fmt::format("{:.3g}", ms);
    }

    /// RMS error targets of the time-to-accuracy table, % of the diagonal.
    constexpr double accuracy_targets[] = { 5.0, 2.0, 1.0, 0.5 };

    /// The time-to-accuracy table of a scene: per method (row) and RMS target (column), the
    /// fastest of its points whose RMS error is at most the target, as "ms (setting)", "-" where
    /// none reaches it; a last row names the fastest method per target.
    std::string time_to_accuracy(const SceneResults& scene)
    {
        std::string md = "| method |";
        std::string rule = "| --- |";
        for (const double target : accuracy_targets) {
            md += fmt::format(" RMS <= {:g}% |", target);
            rule += " ---: |";
        }
        md += "\n" + rule + "\n";
        struct Fastest {
            const Point* point = nullptr;
            const Series* series = nullptr;
        };
        // [0]: the CPU series, [1]: the GPU series (timed on another machine); per target
        Fastest best[2][std::size(accuracy_targets)] = {};
        for (const Series& series : scene.series) {
            md += "| " + series.method + " |";
            for (std::size_t t = 0; t < std::size(accuracy_targets); ++t) {
                const Point* fastest = nullptr;
                for (const Point& p : series.points)
                    if (p.rms <= accuracy_targets[t] && (!fastest || p.ms < fastest->ms))
                        fastest = &p;
                md += fastest ? fmt::format(" {} ms ({} {}) |", ms_text(fastest->ms),
                          fastest->value, series.parameter)
                              : std::string(" - |");
                Fastest& b = best[on_gpu(series)][t];
                if (fastest && (!b.point || fastest->ms < b.point->ms))
                    b = { fastest, &series };
            }
            md += "\n";
        }
        for (const bool gpu : { false, true }) {
            if (gpu && !has_gpu_series(scene))
                break;
            md += gpu ? "| **fastest on the GPU** |" : "| **fastest** |";
            for (const Fastest& b : best[gpu])
                md += b.point
                    ? fmt::format(" **{}**, {} ms |", b.series->method, ms_text(b.point->ms))
                    : std::string(" - |");
            md += "\n";
        }
        return md;
    }

    std::string markdown(const std::vector<SceneResults>& scenes, const std::string& chart_dir,
        const std::string& note)
    {
        std::string md;
        if (!note.empty())
            md += fmt::format("Generated by `docs/make_charts.sh`; {}.\n", note);
        for (const SceneResults& scene : scenes) {
            md += fmt::format(
                "\n#### {}\n\n![{}]({}/{}.svg)\n\n", scene.name, scene.name, chart_dir, scene.name);
            md += "Time to accuracy: the fastest setting of each method whose RMS error is at most "
                  "the target, ms per step (setting).\n\n"
                + time_to_accuracy(scene) + "\nEvery point:\n\n";
            md += "\"front\": on the Pareto front of RMS error against time (no other point is "
                  "as fast or faster with as little error or less)";
            md += has_gpu_series(scene) ? "; the GPU runs, timed on another machine, are not on "
                                          "it: \"GPU front\" marks their own front.\n\n"
                                        : ".\n\n";
            md += "| method | setting | ms/step | RMS % | max % | front |\n| --- | --- | ---: | "
                  "---: | ---: | --- |\n";
            const std::vector<const Point*> front = pareto_front(scene, 0);
            const std::vector<const Point*> gpu_front = pareto_front(scene, 0, true);
            const auto front_mark = [&](const Point& p) {
                if (std::find(front.begin(), front.end(), &p) != front.end())
                    return "yes";
                return std::find(gpu_front.begin(), gpu_front.end(), &p) != gpu_front.end()
                    ? "GPU front"
                    : "";
            };
            for (const Series& series : scene.series)
                for (const Point& p : series.points)
                    md += fmt::format("| {} | {} {} | {} | {:.3g} | {:.3g} | {} |\n", series.method,
                        p.value, series.parameter, ms_text(p.ms), p.rms, p.max, front_mark(p));
        }
        return md;
    }

    int run(int argc, char** argv)
    {
        std::vector<std::string> args(argv + 1, argv + argc);
        std::string note;
        std::string link_dir = "charts"; // the charts' folder as TABLE.md's page links it
        for (std::size_t i = 0; i + 1 < args.size();)
            if (args[i] == "--note" || args[i] == "--link-dir") {
                (args[i] == "--note" ? note : link_dir) = args[i + 1];
                args.erase(args.begin() + long(i), args.begin() + long(i) + 2);
            } else
                ++i;
        if (args.size() != 3) {
            std::fputs("usage: speed_accuracy_chart RESULTS.csv OUT_DIR TABLE.md [--note TEXT] "
                       "[--link-dir DIR]\n",
                stderr);
            return 2;
        }
        const std::vector<SceneResults> scenes = read_results(args[0]);
        // Every SVG is rendered before any is written, so bad data leaves no output.
        std::vector<std::string> svgs;
        for (const SceneResults& scene : scenes)
            svgs.push_back(scene_svg(scene, note));
        for (std::size_t i = 0; i < scenes.size(); ++i) {
            text_io::write_file_atomically(args[1] + "/" + scenes[i].name + ".svg", svgs[i]);
            std::printf("wrote %s/%s.svg\n", args[1].c_str(), scenes[i].name.c_str());
        }
        // The table goes into docs/benchmarks.md, which links the charts relative to itself.
        text_io::write_file_atomically(args[2], markdown(scenes, link_dir, note));
        std::printf("wrote %s\n", args[2].c_str());
        return 0;
    }

} // namespace
} // namespace mat

int main(int argc, char** argv)
{
    try {
        return mat::run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "speed_accuracy_chart: error: %s\n", e.what());
        return 1;
    }
}
