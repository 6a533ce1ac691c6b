#include "preprocess/bake_cli.hpp"

int main(int argc, char** argv)
{
    return mat::bake_main(argc, argv);
}
