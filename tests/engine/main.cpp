#define CATCH_CONFIG_RUNNER
#include <iostream>
#include <string>

#include <catch2/catch.hpp>

#include "interactions/gravity_direct.hpp"
#include "interactions/pair_filter.hpp"

int main(int argc, char* argv[]) {
  // The benchmarks and tests pick their kernels by these variables, as the runner does: a misspelt one would run the
  // widest kernels unsaid, whose figures could be quoted as the ones asked for.
  for (const std::string& problem : {grains::pair_filter::environment_problem(), grains::gravity_direct::environment_problem()})
    if (!problem.empty()) {
      std::cerr << "grains_tests: " << problem << "\n";
      return 2;
    }
  return Catch::Session().run(argc, argv);
}
