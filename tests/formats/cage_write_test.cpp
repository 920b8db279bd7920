// Cage writers (issue 43): every format read_cage reads, written and read back exactly.
#include "formats/cage_write.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "common/error.h"
#include "formats/cage_io.h"
#include "tests/support/procedural.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"

namespace fissure::formats {
namespace {

using testing::TempDir;

using testing::bytes_of;

/// A grid cage with coordinates that need all 17 digits to come back bit-identical.
TetMesh awkward_cage() {
  TetMesh cage = testing::grid_cage(Vec3(0.1, -1.0 / 3.0, 1e-7), Vec3(2.0 / 7.0, 0.7, 12345.678901234567), 2, 3, 2);
  cage.rest_positions(0, 1) = std::nextafter(cage.rest_positions(0, 1), 1.0);
  return cage;
}

TEST(CageWriter, EveryFormatReadsBackBitIdentical) {
  TempDir dir;
  const TetMesh cage = awkward_cage();
  for (const char* name : {"c.node", "c.msh", "c.mesh"}) {
    write_cage(cage, dir / name);
    const CageFile back = read_cage(dir / name);
    EXPECT_EQ(back.mesh.rest_positions, cage.rest_positions) << name;
    EXPECT_EQ(back.mesh.tets, cage.tets) << name;
    EXPECT_EQ(back.flipped_tets, 0u) << name;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "c.ele"));
  EXPECT_EQ(read_cage(dir / "c.msh").format, "gmsh-2.2");
  EXPECT_EQ(read_cage(dir / "c.mesh").format, "medit");
}

TEST(CageWriter, TheSameCageGivesTheSameBytes) {
  TempDir dir;
  write_cage(awkward_cage(), dir / "a.msh");
  write_cage(awkward_cage(), dir / "b.msh");
  EXPECT_EQ(bytes_of(dir / "a.msh"), bytes_of(dir / "b.msh"));
  EXPECT_EQ(bytes_of(dir / "a.msh"), gmsh_text(awkward_cage()));
}

TEST(CageWriter, AnUnknownExtensionOrUnwritableFolderIsAnErrorAndWritesNothing) {
  TempDir dir;
  testing::expect_error_containing([&] { write_cage(awkward_cage(), dir / "c.vtk"); }, {"c.vtk", "unknown cage format", ".msh"});
  EXPECT_FALSE(std::filesystem::exists(dir / "c.vtk"));
  testing::expect_error_containing([&] { write_cage(awkward_cage(), dir / "missing" / "c.node"); }, {"missing"});
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
  EXPECT_TRUE(is_cage_path("x.NODE"));
  EXPECT_FALSE(is_cage_path("x.obj"));
}

}  // namespace
}  // namespace fissure::formats
