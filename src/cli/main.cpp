#include <cstdio>
int main() { std::puts("ugvr"); return 0; }
