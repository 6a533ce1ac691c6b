#include "preprocess/cli/sample_command.hpp"

#include <cstdio>
#include <filesystem>

#include "common/cli.hpp"
#include "common/timer.hpp"
#include "preprocess/samples/sample_generator.hpp"

namespace mat {

CLI::App* add_sample_command(CLI::App& app, SampleCommandOptions& options)
{
    std::string names = "all";
    for (const std::string& name : list_samples())
        names += ", " + name;
    CLI::App* sample = app.add_subcommand(
        "sample", "Generate a bundled sample: a surface and its exact medial mesh");
    sample->add_option("name", options.name, "Which sample: " + names)->required();
    sample
        ->add_option("-o,--output", options.output,
            "Directory; each sample goes to DIR/NAME/NAME.obj and NAME.ma")
        ->required();
    sample
        ->add_option("--facet-size", options.facet_size,
            "Surface facet size as a fraction of the bbox diagonal (0: the sample's "
            "default)")
        ->capture_default_str();
    sample->add_option("--detail", options.detail, "Creature only: 1 to 5 (49 to 145 spheres)")
        ->capture_default_str()
        ->check(whole_number_in(1, 5));
    return sample;
}

void run_sample_command(const SampleCommandOptions& options)
{
    std::vector<std::string> names;
    if (options.name == "all")
        names = list_samples();
    else
        names.push_back(options.name);
    for (const std::string& name : names) {
        Timer timer;
        SampleOptions sample_options;
        sample_options.facet_size = options.facet_size;
        sample_options.detail = options.detail;
        const Sample sample = make_sample(name, sample_options);
        const std::string directory = (std::filesystem::path(options.output) / name).string();
        write_sample(sample, directory);
        std::printf("%s: %lld spheres, %lld cones, %lld slabs; surface %lld vertices, %lld faces "
                    "-> %s/%s.{obj,ma} (%.2f s)\n",
            name.c_str(), static_cast<long long>(sample.medial.num_spheres()),
            static_cast<long long>(sample.medial.num_cones()),
            static_cast<long long>(sample.medial.num_slabs()),
            static_cast<long long>(sample.surface.num_vertices()),
            static_cast<long long>(sample.surface.num_faces()), directory.c_str(), name.c_str(),
            timer.seconds());
    }
}

} // namespace mat
