#include "runtime/run_cli.hpp"

int main(int argc, char** argv)
{
    return mat::run_main(argc, argv);
}
