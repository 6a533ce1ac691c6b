// stability_summary STATS.json QUIET_FROM
//
// One line of figures from a `mat-run --stats` file for the stability study
// (docs/make_stability.sh): whether the energy stayed bounded, the largest strain, the deepest
// penetration, the error against the reference run and the solver time per step. Prints
//
//   energy=bounded|rising rise=R max_strain=S final_strain=F max_penetration=P rms=A max=B
//   ms_per_step=T
//
// Energy criterion: once nothing drives the scene any more (from time QUIET_FROM, s: after the
// last pin keyframe, or 0 for a passive scene), the total energy (kinetic + gravitational
// potential + elastic, summed over the bodies) may not rise. Implicit Euler only dissipates and
// static pins, planes and gravity do no work, so a rise beyond 1% of the magnitude of the
// energy at QUIET_FROM plus 1e-6 J is energy the solver made up. R is the largest rise, J.
// F is the largest strain at the last frame (has a crushed body recovered?).
// rms and max are the stats' reference_error (mat-run --reference), "n/a" without one.
// T is the solver's wall time per step (local, right-hand side, solve, reconstruction,
// contact, plus collision detection), ms. Exit 1 with one line on an unreadable file.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace mat {
namespace {

    double number_or_zero(const nlohmann::json& j, const char* key)
    {
        const auto it = j.find(key);
        return it != j.end() && it->is_number() ? it->get<double>() : 0.0;
    }

    double sum_numbers(const nlohmann::json& j)
    {
        double sum = 0.0;
        if (j.is_object())
            for (const auto& [key, value] : j.items())
                if (value.is_number() && key != "export")
                    sum += value.get<double>();
        return sum;
    }

    int summarize(const std::string& path, double quiet_from)
    {
        std::ifstream in(path);
        if (!in) {
            std::fprintf(stderr, "stability_summary: %s: cannot open\n", path.c_str());
            return 1;
        }
        nlohmann::json stats;
        try {
            in >> stats;
        } catch (const nlohmann::json::exception& e) {
            std::fprintf(stderr, "stability_summary: %s: not JSON (%s)\n", path.c_str(), e.what());
            return 1;
        }
        const auto frames = stats.find("frames");
        if (frames == stats.end() || !frames->is_array() || frames->empty()) {
            std::fprintf(stderr, "stability_summary: %s: no frames\n", path.c_str());
            return 1;
        }

        double max_strain = 0.0, final_strain = 0.0, max_penetration = 0.0;
        bool have_quiet = false;
        double quiet_energy = 0.0, rise = 0.0;
        // Frame times are multiples of dt written in decimal: compare with a little slack.
        const double slack = 1e-6;
        for (const auto& frame : *frames) {
            double total = 0.0;
            final_strain = 0.0;
            for (const auto& body : frame.value("bodies", nlohmann::json::array())) {
                max_strain = std::max(max_strain, number_or_zero(body, "max_strain"));
                final_strain = std::max(final_strain, number_or_zero(body, "max_strain"));
                if (body.contains("energy"))
                    total += number_or_zero(body["energy"], "total");
                if (body.contains("contact"))
                    max_penetration = std::max(
                        max_penetration, number_or_zero(body["contact"], "max_penetration"));
            }
            for (const char* key : { "collision", "collision_check" })
                if (frame.contains(key))
                    max_penetration
                        = std::max(max_penetration, number_or_zero(frame[key], "max_penetration"));
            const double time = number_or_zero(frame, "time");
            if (time + slack < quiet_from)
                continue;
            if (!have_quiet) {
                have_quiet = true;
                quiet_energy = total;
            }
            rise = std::max(rise, total - quiet_energy);
        }
        const bool bounded = rise <= 0.01 * std::abs(quiet_energy) + 1e-6;

        const double ms_per_step = sum_numbers(stats.value("ms_per_step", nlohmann::json::object()))
            + sum_numbers(stats.value("collision_ms_per_step", nlohmann::json::object()));
        std::string rms = "n/a", max = "n/a";
        if (const auto error = stats.find("reference_error"); error != stats.end()) {
            char text[64];
            std::snprintf(text, sizeof text, "%.3g", number_or_zero(*error, "rms_percent"));
            rms = text;
            std::snprintf(text, sizeof text, "%.3g", number_or_zero(*error, "max_percent"));
            max = text;
        }
        std::printf("energy=%s rise=%.3g max_strain=%.3g final_strain=%.3g max_penetration=%.3g "
                    "rms=%s max=%s "
                    "ms_per_step=%.3g\n",
            bounded ? "bounded" : "rising", rise, max_strain, final_strain, max_penetration,
            rms.c_str(), max.c_str(), ms_per_step);
        return 0;
    }

} // namespace
} // namespace mat

int main(int argc, char** argv)
{
    if (argc != 3) {
        std::fprintf(stderr, "usage: stability_summary STATS.json QUIET_FROM_SECONDS\n");
        return 2;
    }
    char* end = nullptr;
    const double quiet_from = std::strtod(argv[2], &end);
    if (end == argv[2] || *end != '\0' || !std::isfinite(quiet_from)) {
        std::fprintf(stderr, "stability_summary: QUIET_FROM '%s' is not a number\n", argv[2]);
        return 2;
    }
    return mat::summarize(argv[1], quiet_from);
}
