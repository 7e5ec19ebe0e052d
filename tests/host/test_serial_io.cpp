// The byte streams under the host controller on a real pseudo-terminal: the serial port (raw,
// exclusive, pty ioctls tolerated) against the pty's master side, an independent serial client
// (Debian's python3-serial) on the linked path, hang-ups, and the link's life cycle.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "delta/io/pseudo_terminal.hpp"
#include "delta/io/serial_port.hpp"

namespace delta::io {
namespace {

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "delta_io_" + std::to_string(::getpid()) + "_" + name;
}

// Everything that arrives on `stream` within timeout_ms, until `count` bytes are in.
std::vector<std::uint8_t> read_bytes(ByteStream& stream, std::size_t count, int timeout_ms = 2000) {
  std::vector<std::uint8_t> bytes;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (bytes.size() < count && std::chrono::steady_clock::now() < deadline) {
    pollfd p{stream.fd(), POLLIN, 0};
    ::poll(&p, 1, 20);
    std::uint8_t buffer[256];
    const std::size_t got = stream.read_some(buffer, sizeof buffer);
    bytes.insert(bytes.end(), buffer, buffer + got);
  }
  return bytes;
}

TEST(SerialIo, SerialPortAndPtyCarryEveryByteValueBothWays) {
  const std::string link = temp_path("board");
  PseudoTerminal pty(link);
  SerialPort port(link, 1000000);
  EXPECT_FALSE(port.info().low_latency);  // a pty has no such flag: tolerated and said
  EXPECT_NE(port.info().notes.find("TIOCGSERIAL"), std::string::npos) << port.info().notes;

  std::vector<std::uint8_t> all(256);
  for (int i = 0; i < 256; ++i) all[i] = static_cast<std::uint8_t>(i);  // raw: no byte is special
  port.write_all(all.data(), all.size());
  EXPECT_EQ(read_bytes(pty, all.size()), all);
  pty.write_all(all.data(), all.size());
  EXPECT_EQ(read_bytes(port, all.size()), all);
}

TEST(SerialIo, SecondOpenerIsRefusedWhileThePortIsHeld) {
  const std::string link = temp_path("exclusive");
  PseudoTerminal pty(link);
  SerialPort first(link, 115200);
  try {
    SerialPort second(link, 115200);
    FAIL() << "a second opener was accepted";
  } catch (const std::system_error& error) {
    EXPECT_NE(std::string(error.what()).find(link), std::string::npos) << error.what();
  }
}

TEST(SerialIo, MissingDeviceNamesThePathAndWhatToCheck) {
  const std::string path = temp_path("no_such_device");
  try {
    SerialPort port(path, 115200);
    FAIL() << "opened a missing device";
  } catch (const std::system_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find("plugged in"), std::string::npos) << message;
    EXPECT_NE(message.find("virtual board"), std::string::npos) << message;  // not under /dev: maybe a pty
  }
  try {
    SerialPort port("/dev/serial/by-id/no-such-board", 115200);
    FAIL() << "opened a missing device";
  } catch (const std::system_error& error) {
    EXPECT_NE(std::string(error.what()).find("see /dev/serial/by-id/"), std::string::npos) << error.what();
  }
  EXPECT_THROW(SerialPort(path, 123456), std::invalid_argument);  // no termios constant
}

TEST(SerialIo, ClosingThePtyHangsUpTheClient) {
  const std::string link = temp_path("hangup");
  auto pty = std::make_unique<PseudoTerminal>(link);
  SerialPort port(link, 115200);
  pty.reset();  // the virtual board goes away
  struct stat status {};
  EXPECT_NE(::lstat(link.c_str(), &status), 0) << "the link outlived the pty";
  std::uint8_t byte = 0;
  EXPECT_THROW(
      {
        for (int i = 0; i < 100; ++i) {
          port.read_some(&byte, 1);
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
      },
      std::system_error);
}

TEST(SerialIo, LinkPathRefusesARegularFileAndReplacesAStaleLink) {
  const std::string file = temp_path("regular");
  std::ofstream(file) << "keep me";
  EXPECT_THROW(PseudoTerminal pty(file), std::system_error);
  std::ifstream in(file);
  std::string kept;
  std::getline(in, kept);
  EXPECT_EQ(kept, "keep me");
  std::remove(file.c_str());

  const std::string stale = temp_path("stale");
  ASSERT_EQ(::symlink("/dev/pts/999999", stale.c_str()), 0);
  PseudoTerminal pty(stale);
  char target[128] = {};
  ASSERT_GT(::readlink(stale.c_str(), target, sizeof target - 1), 0);
  EXPECT_EQ(std::string(target), pty.slave_path());
}

// An independent client (Debian's python3-serial, not project code) opens the linked path as a
// serial port, writes a request and reads the answer.
TEST(SerialIo, IndependentPySerialClientTalksThroughTheLink) {
  const std::string link = temp_path("pyserial");
  PseudoTerminal pty(link);
  const std::string out = temp_path("pyserial.out");
  const std::string command = "/usr/bin/python3 -c \"import serial, sys; s = serial.Serial('" + link +
                              "', 1000000, timeout=2); s.write(bytes([0x7e, 0x00, 0xff, 0x10])); "
                              "sys.stdout.write(s.read(3).hex())\" > " +
                              out + " 2>&1";
  std::thread client([&] { std::system(command.c_str()); });
  const std::vector<std::uint8_t> request = read_bytes(pty, 4, 5000);
  const std::vector<std::uint8_t> reply = {0xca, 0xfe, 0x01};
  pty.write_all(reply.data(), reply.size());
  client.join();
  EXPECT_EQ(request, (std::vector<std::uint8_t>{0x7e, 0x00, 0xff, 0x10}));
  std::ifstream in(out);
  std::string answer;
  std::getline(in, answer);
  EXPECT_EQ(answer, "cafe01") << "python3-serial said: " << answer
                              << " (bash scripts/setup.sh installs python3-serial)";
}

}  // namespace
}  // namespace delta::io
