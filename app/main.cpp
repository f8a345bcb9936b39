#include "app/cli.h"

int main(int argc, char** argv) { return handson::cli::run(argc, argv); }
